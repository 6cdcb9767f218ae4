"""The main job end to end, as one function: ``run_demo(out_dir)``.

It records the Go2 mapping tour of ``indoor_room`` to MCAP, replays the log through the mapping
pipeline (2D occupancy map, 3D LiDAR map and trajectory), writes the world's reference map and mesh
and computes the metrics against them, and writes a Rerun recording. ``navlog demo`` calls it and
prints what it reports; a Python user gets the same files and the same numbers.

Outputs in ``out_dir``: ``mapping.mcap`` (the log), ``replay/`` (map.yaml + map.pgm, map.pcd,
trajectory.tum, replay.mcap, manifest.json), ``reference/`` (``world_scan_plane.yaml`` at the
scan plane, ``world_nav2.yaml`` with Nav2's 0.15 m margin, ``world.ply``), ``metrics.json`` and
``demo.rrd``.
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navlog.errors import NavlogError

if TYPE_CHECKING:
    import threading

    from navlog.analysis.view import ViewSummary
    from navlog.recorder.record import RecordResult
    from navlog.replay import ReplayResult

WORLD = "indoor_room"
ROBOT = "go2"
SCENARIO = "mapping"
PIPELINE = "mapping"
RESOLUTION = 0.05  # m per cell of the reference maps
NAV2_MARGIN = 0.15  # m: the safety margin of the Go2 setup's Nav2 map


@dataclass
class DemoResult:
    """What ``run_demo`` did; the steps that did not run (``interrupted``) leave their fields empty."""

    out_dir: Path
    recording: RecordResult
    replay: ReplayResult | None = None
    metrics: dict[str, Any] = field(default_factory=dict)
    view: ViewSummary | None = None
    wall_s: float = 0.0

    interrupted: bool = False  # ``stop`` ended the demo before its last step

    @property
    def metrics_json(self) -> Path:
        return self.out_dir / "metrics.json"

    @property
    def rrd(self) -> Path:
        return self.out_dir / "demo.rrd"


def _prepare_output(out_dir: Path, force: bool) -> None:
    if out_dir.exists() and any(out_dir.iterdir()):
        if not force:
            raise NavlogError(f"{out_dir}: output folder exists and is not empty; pass --force to replace it")
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)


def _stopped(result: DemoResult, stop: threading.Event | None, t0: float) -> bool:
    result.interrupted = result.recording.interrupted or (stop is not None and stop.is_set())
    result.wall_s = time.perf_counter() - t0
    return result.interrupted


def run_demo(
    out_dir: Path | str,
    *,
    seed: int = 7,
    force: bool = False,
    progress: bool = True,
    echo: Callable[[str], None] | None = None,
    stop: threading.Event | None = None,
) -> DemoResult:
    """Record, replay, measure and draw the Go2 mapping tour of indoor_room into ``out_dir``.

    ``seed`` seeds all sensor and odometry noise. ``force`` replaces a non-empty ``out_dir``
    (otherwise a ``NavlogError``). ``progress`` shows progress bars on stderr. ``echo`` is called
    with the text of each stage as it starts and ends (``print`` shows what ``navlog demo`` shows).
    ``stop``, when set, ends the demo after the current step (the recording stops at once and
    closes its log cleanly); the result then says ``interrupted``.
    """
    from navlog.analysis.metrics import MetricsOptions, compute_metrics, format_table, write_json
    from navlog.analysis.view import save_view
    from navlog.recorder.record import format_summary, prepare, record
    from navlog.recorder.world import write_world_map
    from navlog.replay import run_replay

    def say(text: str) -> None:
        if echo is not None:
            echo(text)

    out = Path(out_dir)
    _prepare_output(out, force)
    t0 = time.perf_counter()

    say(f"== 1/4 record: {WORLD} + {ROBOT} + {SCENARIO}")
    setup = prepare(WORLD, ROBOT, SCENARIO, seed=seed)
    rec = record(setup, out / "mapping.mcap", progress=progress, stop=stop)
    say(format_summary(rec))
    result = DemoResult(out, rec)
    if _stopped(result, stop, t0):
        return result

    say(f"\n== 2/4 replay through the {PIPELINE} pipeline")
    rep = run_replay(rec.path, PIPELINE, out / "replay", progress=progress)
    say(
        f"replayed {rep.log_s:.1f} s of log in {rep.wall_s:.1f} s into {rep.out_dir}/: "
        + ", ".join(o["file"] for o in rep.manifest["outputs"].values())
    )
    result.replay = rep
    if _stopped(result, stop, t0):
        return result

    say("\n== 3/4 metrics against the world's true geometry")
    ref = out / "reference"
    ref.mkdir()
    scan = setup.robot.scan
    if scan is None:
        raise NavlogError(f"robot {setup.robot.name}: the demo needs a 2D laser (scan)")
    scan_height = setup.robot.body.height + scan.mount[2]
    map_yaml = write_world_map(
        setup.world,
        ref / "world_scan_plane.yaml",
        margin=0.0,
        resolution=RESOLUTION,
        z_min=scan_height,
        z_max=scan_height,
    ).yaml_path
    nav2_map = write_world_map(
        setup.world, ref / "world_nav2.yaml", margin=NAV2_MARGIN, resolution=RESOLUTION, mesh=ref / "world.ply"
    )
    mesh = nav2_map.mesh_path
    metrics = compute_metrics(
        rec.path, rep.out_dir, reference_map=map_yaml, reference_mesh=mesh, options=MetricsOptions()
    )
    write_json(metrics, result.metrics_json)
    say(format_table(metrics))
    result.metrics = metrics
    if _stopped(result, stop, t0):
        return result

    say("\n== 4/4 Rerun recording")
    result.view = save_view(rec.path, result.rrd, replay_dir=rep.out_dir)
    say(f"wrote {result.rrd}: {len(result.view.entities)} entities, {result.view.messages} messages drawn")
    result.wall_s = time.perf_counter() - t0
    return result
