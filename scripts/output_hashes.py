"""The sha256 of every output the shipped scenarios and the CI suite produce, as one JSON document.

Records each shipped scenario (seed 0, its own world and robot), replays the logs through every
pipeline that applies, exports them (rosbag2 in both storages, TUM), saves the Rerun views, and runs
the shipped CI suite; then hashes every file written. Two checkouts that give the same document
produce the same bytes:

    python scripts/output_hashes.py --out /tmp/new > new.json
    python scripts/output_hashes.py --out /tmp/old --navlog /path/to/old/.venv/bin/navlog > old.json
    python scripts/output_hashes.py --compare old.json new.json

Only what names the machine or the moment is left out: ``manifest.json``, ``fleet-summary.json`` and
``ci-report.json`` are hashed after their wall-clock fields are dropped and the work folder and the
checkout are replaced by ``OUT`` and ``REPO`` in their paths. A Rerun recording holds random ids and
wall-clock times, and the SDK cuts its rows into chunks as the wall clock goes (two saves of one log
differ in bytes): its entry names the file, and ``--compare`` compares two recordings' contents
(``rerun rrd optimize`` merges each entity's rows into one chunk, then ``rerun rrd compare --unordered``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# scenario -> the pipelines its log is replayed through (with their --set overrides)
SCENARIOS: dict[str, list[tuple[str, list[str]]]] = {
    "mapping": [
        ("mapping", []),
        ("mapping", ["pose_source=slam", "lidar_mapper=off"]),
        ("localization", ["map=@world"]),
    ],
    "teleop": [("mapping", []), ("safety", ["@remap"])],
    "teleop_wall": [("safety", ["@remap"])],
    "teleop_obstacle": [],
    "teleop_reverse": [],
    "nav_tour": [("navigation", ["goals=indoor_room_waypoints", "seed=0"])],
    "nav_kibot": [],
    "nav_simple_robot": [],
    "patrol": [],
    "town_tour": [],
}
VIEWED = {"mapping", "nav_tour", "teleop_wall"}
EXPORTED = {"mapping", "nav_tour"}
# wall-clock fields a manifest or summary holds (not outputs of the computation)
VOLATILE = {"started", "finished", "wall_s", "duration_s", "elapsed_s", "host", "created", "date", "seconds", "timings"}


def _strip(value: object) -> object:
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    return value


def _hash(path: Path, out: Path) -> str:
    if path.suffix == ".rrd":
        return f"rrd:{path}"
    if path.name in ("manifest.json", "fleet-summary.json", "ci-report.json"):
        text = path.read_text().replace(str(out.resolve()), "OUT").replace(str(Path.cwd().resolve()), "REPO")
        try:
            data = json.loads(text)
        except ValueError:
            pass
        else:
            return "json:" + hashlib.sha256(json.dumps(_strip(data), sort_keys=True).encode()).hexdigest()
    h = hashlib.sha256()
    with path.open("rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


def _hash_tree(root: Path, out: Path) -> dict[str, str]:
    if root.is_file():
        return {str(root.relative_to(out)): _hash(root, out)}
    return {str(p.relative_to(out)): _hash(p, out) for p in sorted(root.rglob("*")) if p.is_file()}


def _run(cmd: list[str], log: list[str]) -> None:
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    log.append(f"{time.perf_counter() - t:7.1f} s  rc={proc.returncode}  {' '.join(cmd[1:])}")
    print(log[-1], file=sys.stderr)
    if proc.returncode not in (0, 1):
        print(proc.stderr[-2000:], file=sys.stderr)


def collect(navlog: str, out: Path, only: set[str] | None) -> dict[str, str]:
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    log: list[str] = []
    for scenario, replays in SCENARIOS.items():
        if only and scenario not in only:
            continue
        rec = out / f"{scenario}.mcap"
        _run([navlog, "-q", "record", "--scenario", scenario, "--seed", "0", "-o", str(rec)], log)
        for i, (pipeline, sets) in enumerate(replays):
            args = [x for s in sets if not s.startswith("@") for x in ("--set", s)]
            if "@remap" in sets:  # a teleop log's commands into the safety filters, as the CI suite does
                args += ["--remap", "/cmd_vel_nav=/cmd_vel"]
            if "map=@world" in sets:  # the world's own map for AMCL
                wm = out / f"{scenario}-worldmap.yaml"
                _run([navlog, "-q", "world-map", "indoor_room", "--margin", "0", "--height", "0.2", "-o", str(wm)], log)
                args = ["--set", f"map={wm}"] + [a for a in args if a not in ("--set", "map=@world")]
            _run(
                [
                    navlog,
                    "-q",
                    "replay",
                    str(rec),
                    "--pipeline",
                    pipeline,
                    *args,
                    "-o",
                    str(out / f"{scenario}-{pipeline}-{i}"),
                ],
                log,
            )
        if scenario in EXPORTED:
            _run([navlog, "-q", "export", str(rec), "--to", "rosbag2", "-o", str(out / f"{scenario}-bag")], log)
            _run(
                [
                    navlog,
                    "-q",
                    "export",
                    str(rec),
                    "--to",
                    "rosbag2",
                    "--storage",
                    "mcap",
                    "-o",
                    str(out / f"{scenario}-bag-mcap"),
                ],
                log,
            )
            _run(
                [
                    navlog,
                    "-q",
                    "export",
                    str(rec),
                    "--to",
                    "tum",
                    "--topic",
                    "/odom/ground_truth",
                    "-o",
                    str(out / f"{scenario}.tum"),
                ],
                log,
            )
        if scenario in VIEWED:
            _run([navlog, "-q", "view", str(rec), "--save", str(out / f"{scenario}.rrd")], log)
            if replays:
                replay = out / f"{scenario}-{replays[0][0]}-0"
                _run(
                    [
                        navlog,
                        "-q",
                        "view",
                        str(rec),
                        "--replay",
                        str(replay),
                        "--save",
                        str(out / f"{scenario}-replay.rrd"),
                    ],
                    log,
                )
    if not only or "ci" in only:
        ci = out / "ci"
        ci.mkdir()
        suite = Path.cwd() / "config" / "suites" / "navlog.yaml"  # the checkout run from
        _run(
            [navlog, "-q", "ci", "run", str(suite), "--cache", str(ci / "cache"), "--json", str(ci / "ci-report.json")],
            log,
        )
    hashes: dict[str, str] = {}
    for path in sorted(out.iterdir()):
        hashes.update(_hash_tree(path, out))
    return hashes


def _same(x: str | None, y: str | None) -> bool:
    if x is not None and y is not None and x.startswith("rrd:") and y.startswith("rrd:"):
        # the SDK cuts the rows into chunks as the wall clock goes: merge each entity's rows into one
        # chunk on both sides, then compare the chunks in any order
        rerun = str(Path(sys.executable).parent / "rerun")
        with tempfile.TemporaryDirectory() as tmp:
            merged = []
            for k, path in enumerate((x[4:], y[4:])):
                out = f"{tmp}/{k}.rrd"
                cmd = [rerun, "rrd", "optimize", "--max-rows", "100000000", "--max-size", "4GiB", path, "-o", out]
                subprocess.run(cmd, capture_output=True, check=True)
                merged.append(out)
            return (
                subprocess.run([rerun, "rrd", "compare", "--unordered", *merged], capture_output=True).returncode == 0
            )
    return x == y


def compare(a: dict[str, str], b: dict[str, str]) -> int:
    bad = 0
    for key in sorted(set(a) | set(b)):
        if not _same(a.get(key), b.get(key)):
            bad += 1
            print(f"DIFFERS  {key}: {a.get(key, '-')[:16]} {b.get(key, '-')[:16]}")
    print(f"{len(set(a) | set(b)) - bad} outputs identical, {bad} differ")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, help="work folder (replaced)")
    ap.add_argument("--navlog", default=str(Path(sys.executable).parent / "navlog"), help="the navlog command to run")
    ap.add_argument("--only", nargs="*", help="scenarios (and 'ci') to run; default: all")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("OLD", "NEW"))
    args = ap.parse_args()
    if args.compare:
        return compare(json.loads(args.compare[0].read_text()), json.loads(args.compare[1].read_text()))
    if args.out is None:
        ap.error("--out is required")
    json.dump(
        collect(args.navlog, args.out, set(args.only) if args.only else None), sys.stdout, indent=1, sort_keys=True
    )
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
