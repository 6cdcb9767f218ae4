"""2D SLAM (``--pipeline mapping --set pose_source=slam``): accuracy and replay speed.

Records go2's mapping tour (138 s) and, with ``--patrol``, the 10-minute patrol (six loops) in
indoor_room with ``--localization none`` (no map -> odom in /tf: a real robot's log; the ground
truth topic stays for the evaluation only), unless ``--mapping-log`` / ``--patrol-log`` name them.
Each log is replayed in a fresh process twice: through SLAM, and through the 2D mapper on raw
odometry (``pose_source=odom``: what mapping without SLAM gives). For each it prints ATE (RMSE after
SE(3) alignment, against /odom/ground_truth), the 2D map's F1 and F1 (observable) against
``navlog world-map indoor_room --margin 0`` (tau 0.05 m), the loop closures, and the speed: sim
seconds per wall second and per CPU second of the whole process (start-up, reading, SLAM,
writing), with the load average before and after. Nothing is asserted.

The peer is slam_toolbox (whose parameter names and defaults the SLAM reads); it needs ROS and is
not run here: the targets are ATE <= 5 cm, F1 (observable) >= 0.95 and >= 20x real time for a
10 Hz 720-beam scan. ``--bags`` also maps the real bags of external-data/bags/ in place, in the external data folder
(``--shared DIR``; default ``$NAVLOG_SHARED_DIR``, else ``shared`` beside the repository).

    .venv/bin/python benchmarks/bench_slam.py [--patrol] [--bags] [--mapping-log X.mcap] [--patrol-log Y.mcap] [--shared DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from navlog.analysis.metrics import compute_metrics

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data
from tests.shared_data import default_shared_dir

NAVLOG = [sys.executable, "-m", "navlog", "-q"]


def load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def run(args: list[str]) -> tuple[float, float]:
    """Run navlog in a fresh process: (wall s, CPU s of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([*NAVLOG, *args], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def record(scenario: str, out: Path) -> Path:
    if not out.exists():
        print(f"recording {scenario} with --localization none -> {out}", flush=True)
        run(["record", "--scenario", scenario, "--localization", "none", "-o", str(out)])
    return out


def replay(log: Path, out: Path, pose_source: str) -> tuple[float, float]:
    sets = [f"pose_source={pose_source}", "lidar_mapper=off"]
    return run(
        [
            "replay",
            str(log),
            "--pipeline",
            "mapping",
            "-o",
            str(out),
            "--force",
            *(a for s in sets for a in ("--set", s)),
        ]
    )


def sim_seconds(log: Path) -> float:
    from navlog.replay.io import open_log

    with open_log(log) as reader:
        return (reader.end_ns - reader.start_ns) / 1e9


def evaluate(name: str, log: Path, reference: Path, work: Path) -> None:
    sim = sim_seconds(log)
    print(f"\n{name}: {log} ({sim:.0f} s of sim time), load average before {load()}")
    print(
        f"  {'pose source':<12} {'ATE rmse':>9} {'F1':>6} {'F1 obs':>7} {'loops':>6} {'x real time (wall)':>19} {'x (CPU)':>8}"
    )
    for source in ("slam", "odom"):
        out = work / f"{name}-{source}"
        wall, cpu = replay(log, out, source)
        m = compute_metrics(log, out, reference_map=reference)
        ate = m["trajectory"]["ate"]["translation_m"]["rmse"]
        grid = m["map_2d"]
        loops = "-"
        if source == "slam":
            graph = json.loads((out / "pose_graph.json").read_text())
            loops = str(sum(e["kind"] == "loop" for e in graph["edges"]))
        print(
            f"  {source:<12} {ate * 100:>7.2f}cm {grid['f1']:>6.3f} {grid['f1_observable']:>7.3f} {loops:>6}"
            f" {sim / wall:>18.1f}x {sim / cpu:>7.1f}x"
        )
    print(f"  load average after {load()}")


def bags(shared: Path, work: Path) -> None:
    print("\nreal bags (pose_source=slam, read in place):")
    for bag in ("neato_drive_square", "tb3_gazebo_walker"):
        out = work / bag
        wall, _ = run(
            [
                "replay",
                str(shared / "external-data" / "bags" / bag),
                "--pipeline",
                "mapping",
                "-o",
                str(out),
                "--force",
                "--set",
                "pose_source=slam",
            ]
        )
        graph = json.loads((out / "pose_graph.json").read_text())
        manifest = json.loads((out / "manifest.json").read_text())
        print(
            f"  {bag}: {len(graph['nodes'])} keyframes, {len(graph['edges'])} edges, {wall:.1f} s wall, "
            f"skipped {sum(manifest['skipped'].values())} input(s)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mapping-log", type=Path, help="a mapping log recorded with --localization none")
    ap.add_argument("--patrol", action="store_true", help="also the 10-minute patrol (recorded if not given)")
    ap.add_argument("--patrol-log", type=Path, help="a patrol log recorded with --localization none")
    ap.add_argument("--bags", action="store_true", help="also map the real bags with pose_source=slam")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder (--bags)")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores, load average {load()}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        reference = work / "room.yaml"
        run(["world-map", "indoor_room", "--margin", "0", "-o", str(reference)])
        evaluate("mapping", args.mapping_log or record("mapping", work / "mapping.mcap"), reference, work)
        if args.patrol or args.patrol_log:
            evaluate("patrol", args.patrol_log or record("patrol", work / "patrol.mcap"), reference, work)
        if args.bags:
            bags(args.shared, work)


if __name__ == "__main__":
    main()
