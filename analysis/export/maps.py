"""A 3D point map (PCD) as a map_server map: the grid users hand from a 3D mapper to Nav2."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from navlog.errors import NavlogError

MAX_MIN_POINTS = 10**9  # points a cell needs to be occupied


@dataclass(frozen=True)
class PcdMapFiles:
    """What ``pcd_to_map`` wrote and what the map holds."""

    yaml_path: Path
    pgm_path: Path
    width: int
    height: int
    occupied: int
    free: int
    points: int


def pcd_to_map(
    pcd: Path | str,
    output: Path | str,
    *,
    z_min: float,
    z_max: float,
    resolution: float = 0.05,
    min_points: int = 2,
    all_free: bool = False,
    force: bool = False,
) -> PcdMapFiles:
    """Project ``pcd`` between ``z_min`` and ``z_max`` to a map_server map at ``output`` (PGM beside it).

    Cells with at least ``min_points`` points in the band are occupied; cells where only floor points
    (below ``z_min``) were seen are free, or every non-occupied cell with ``all_free``; the rest unknown.
    """
    from navlog.replay.io.logwriter import check_output
    from navlog.replay.io.map_server import save_map
    from navlog.replay.io.pcd import read_pcd
    from navlog.replay.limits import MAX_GRID_RESOLUTION_M, MIN_GRID_RESOLUTION_M
    from navlog.replay.mapping.occupancy import project_points

    pcd, output = Path(pcd), Path(output)
    if not MIN_GRID_RESOLUTION_M <= resolution <= MAX_GRID_RESOLUTION_M:  # (NaN fails both)
        raise NavlogError(
            f"resolution {resolution!r}: must be {MIN_GRID_RESOLUTION_M} to {MAX_GRID_RESOLUTION_M:g} m a cell"
        )
    if not (math.isfinite(z_min) and math.isfinite(z_max)):  # (their order is project_points's check)
        raise NavlogError(f"z_min {z_min!r}, z_max {z_max!r}: must be finite heights")
    if not 1 <= min_points <= MAX_MIN_POINTS:
        raise NavlogError(f"min_points {min_points!r}: must be 1 to {MAX_MIN_POINTS}")
    if not pcd.is_file():
        raise NavlogError(f"{pcd}: no such file")
    check_output(output, force)
    check_output(output.with_suffix(".pgm"), force)
    pts = read_pcd(pcd)
    if len(pts) == 0:
        raise NavlogError(f"{pcd}: no points could be read (is it a PCD file?)")
    try:
        grid = project_points(pts, z_min, z_max, resolution, min_points, None if all_free else z_min)
    except ValueError as exc:
        raise NavlogError(f"{pcd}: {exc}") from None
    yaml_path, pgm_path = save_map(grid, output)
    return PcdMapFiles(
        yaml_path,
        pgm_path,
        grid.width,
        grid.height,
        int((grid.data == 100).sum()),
        int((grid.data == 0).sum()),
        len(pts),
    )
