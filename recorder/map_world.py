"""map_server maps (YAML + image) as worlds: occupied cells become walls.

Each occupied cell (the map's own thresholds, as ``map_server`` reads them) becomes wall of
``wall_height`` metres standing on the floor. Cells are merged into boxes: each row's runs of
occupied cells, then runs with the same columns in consecutive rows into one box (``merge_cells``),
so a straight wall is one box. Free and unknown cells are both free space: nothing stands there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.solids import Solid
from navlog.replay.geometry import se2_compose

DEFAULT_WALL_HEIGHT = 2.0  # m
MAX_WALL_HEIGHT_M = 100.0  # a map's walls at most (1e300 m high boxes left every beam without a hit)
OCCUPIED = 65  # a cell at or above this value (0..100) is a wall: map_server's default occupied_thresh


def is_map_yaml(path: Path) -> bool:
    """True for a YAML file that is a map_server map (it names its ``image``)."""
    if path.suffix not in (".yaml", ".yml") or not path.is_file():
        return False
    from navlog.replay.config import load_yaml

    try:
        doc = load_yaml(path)
    except ConfigError:
        return False
    return isinstance(doc, dict) and "image" in doc and "resolution" in doc


def merge_cells(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Rectangles (row0, col0, rows, cols) that exactly cover the True cells of ``occupied``:
    runs along each row, a run extended down while the next row has a run with the same columns."""
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row
    out: list[tuple[int, int, int, int]] = []
    height = occupied.shape[0]
    for r in range(height + 1):
        runs: set[tuple[int, int]] = set()
        if r < height:
            row = np.concatenate([[False], occupied[r], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(row))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])}
        for key in [k for k in open_runs if k not in runs]:
            r0 = open_runs.pop(key)
            out.append((r0, key[0], r - r0, key[1] - key[0]))
        for key in runs:
            open_runs.setdefault(key, r)
    return sorted(out)


def map_solids(path: Path, wall_height: float = DEFAULT_WALL_HEIGHT) -> tuple[list, list[str]]:
    """The walls of the map_server map ``path`` as box solids, and notes for the summary."""
    from navlog.replay.io.map_server import load_map

    if not 0 < wall_height <= MAX_WALL_HEIGHT_M:
        raise ConfigError(
            f"{path}: wall height must be above 0 and at most {MAX_WALL_HEIGHT_M:g} m, got {wall_height:g} (--wall-height)"
        )
    grid = load_map(path)
    occupied = grid.data >= OCCUPIED
    if not occupied.any():
        raise ConfigError(f"{path}: the map has no occupied cell: nothing to build walls from")
    res = grid.resolution
    ox, oy, oyaw = grid.origin
    solids = []
    for i, (r0, c0, rows, cols) in enumerate(merge_cells(occupied)):
        cx, cy = (c0 + cols / 2) * res, (r0 + rows / 2) * res
        x, y, yaw = se2_compose((ox, oy, oyaw), (cx, cy, 0.0))
        solids.append(Solid(f"wall_{i}", "box", (x, y, wall_height / 2), yaw, (cols * res, rows * res, wall_height)))
    unknown = int((grid.data < 0).sum())
    notes = [
        f"map {path.name}: {int(occupied.sum())} occupied cells as {len(solids)} wall boxes {wall_height:g} m high"
        + (f"; {unknown} unknown cells treated as free" if unknown else "")
    ]
    return solids, notes
