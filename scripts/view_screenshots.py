"""Screenshots of `navlog view`'s default layout in the real Rerun viewer, checked in pixels.

Renders the default blueprint of a mapping log (a `navlog demo` folder: the 138 s Go2 tour of
indoor_room and its mapping replay), a navigation log (`navlog record --scenario nav_tour`: Nav2's
plan, local plan, footprint, goals, both costmaps, the velocity chain and the navigator's events), a safety log (Nav2's velocity smoother and collision monitor
stopping a robot before a box), a real robot's bag without ground truth (neato_drive_square), a
`navlog diff --rrd` of two mapping replays (ground truth against drifting odometry) and the SLAM's
replay of a real building (the Intel lab's bag, `--pipeline mapping --set pose_source=slam`, viewed with
`--replay`: its map, its path and its map -> odom under the bag's scans and odometry),
each with the screenshot tool (`rerun-shot.sh RRD OUT.png`: Xvfb + Mesa's software Vulkan, about
30 to 60 s a shot), and checks each PNG:

- not black (mean brightness above MIN_BRIGHTNESS);
- the robot is visible where the 3D camera starts: pixels of the robot's colour near the centre of
  the 3D view (the top-left panel), with the time cursor at or near the log's start (0, 1, 5 and
  10 s: the robot has moved less than the camera's view around its first pose);
- the viewer's own views report no error (`ViewerClient.get_state()`, printed by the tool).

The PNGs are written small (downscaled, fewer colours) for the README: docs/images/view-*.png.

    .venv/bin/python scripts/view_screenshots.py [--demo DEMO_DIR] [--out docs/images]
        [--shot ../shared/tools/rerun-shot.sh] [--bags DIR] [--only NAME ...]

Exit status 0 when every check passes, 1 when one fails, 2 when the screenshot tool or its
prerequisites are missing (nothing is checked then).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the test suite's log writers

MIN_BRIGHTNESS = 0.05
ROBOT_RGB = (230, 159, 0)  # COLORS["footprint"] of navlog.analysis.view.context
ROBOT_TOLERANCE = 40  # per channel
ROBOT_MIN_PIXELS = 20
OUT_WIDTH = 1200  # px of the saved PNGs


@dataclass
class Shot:
    name: str
    rrd: Path
    time_s: float  # where the time cursor is put (s of sim_time)
    wait_s: int  # how long the viewer renders
    marks: tuple[tuple[int, int, int], ...] = (ROBOT_RGB,)  # colours that must show in the 3D view's middle


def prerequisites(shot: Path) -> str:
    """'' when screenshots can be taken, else what is missing."""
    if not shot.is_file():
        return f"screenshot tool not found: {shot}"
    missing = [b for b in ("Xvfb", "import", "convert", "xdotool") if shutil.which(b) is None]
    if missing:
        return f"screenshot tool prerequisites missing: {', '.join(missing)} (the tool installs them with apt)"
    if not Path("/usr/share/vulkan/icd.d/lvp_icd.x86_64.json").is_file():
        return "Mesa's software Vulkan (lavapipe) is missing: apt-get install mesa-vulkan-drivers"
    return ""


def view_3d_box(width: int, height: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the middle of the 3D view in a screenshot of the default layout: the left
    3/5 of the window's width and the top 3/5 of the views' height (under the viewer's top bar)."""
    top, bottom = 40, height - 30
    h3d = (bottom - top) * 3 // 5
    cx, cy = width * 3 // 10, top + h3d // 2
    return cx - width // 8, cy - h3d // 4, cx + width // 8, cy + h3d // 4


def check_png(path: Path, tool_output: str, marks: tuple[tuple[int, int, int], ...] = (ROBOT_RGB,)) -> list[str]:
    """What is wrong with a screenshot ([] : nothing); ``marks``: colours expected mid 3D view."""
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)
    problems = []
    if img.mean() / 255 < MIN_BRIGHTNESS:
        problems.append(f"almost black (mean brightness {img.mean() / 255:.3f})")
    x0, y0, x1, y1 = view_3d_box(img.shape[1], img.shape[0])
    patch = img[y0:y1, x0:x1]
    for rgb in marks:
        robot = (np.abs(patch - np.array(rgb)) <= ROBOT_TOLERANCE).all(axis=2).sum()
        if robot < ROBOT_MIN_PIXELS:
            what = "robot" if rgb == ROBOT_RGB else f"RGB {rgb}"
            problems.append(f"{what} not visible in the middle of the 3D view ({robot} pixels of its colour)")
    reports = re.search(r"(\d+) view report\(s\)", tool_output)
    if reports is None:
        problems.append("the viewer's state could not be read")
    elif int(reports.group(1)):
        lines = [ln for ln in tool_output.splitlines() if ln.startswith("view '")]
        problems.append(f"{reports.group(1)} view report(s): " + "; ".join(lines))
    return problems


def take(shot_tool: Path, s: Shot, png: Path) -> str:
    env = {"SHOT_TIME": f"{s.time_s:g}", "VENV": str(Path(sys.executable).parents[1])}
    res = subprocess.run(
        ["bash", str(shot_tool), str(s.rrd), str(png), str(s.wait_s)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, **env},
        timeout=600,
    )
    return res.stdout + res.stderr


def shrink(src: Path, dst: Path) -> None:
    """A README-sized copy: OUT_WIDTH wide, 256-colour palette (under 300 KB)."""
    from PIL import Image

    img = Image.open(src).convert("RGB")
    img = img.resize((OUT_WIDTH, round(img.height * OUT_WIDTH / img.width)), Image.LANCZOS)
    img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(dst, optimize=True)


SHOTS = ("mapping", "navigation", "safety", "real-bag", "diff", "slam-real")


def build_rrds(work: Path, demo: Path | None, bags: Path, only: tuple[str, ...] = SHOTS) -> list[Shot]:
    from navlog.analysis.view import save_view
    from navlog.recorder.record import prepare, record
    from tests.analysis.view.safety_log import write_safety_log

    shots = []
    if "mapping" in only:
        if demo is None:
            demo = work / "demo"
            subprocess.run([str(Path(sys.executable).with_name("navlog")), "-q", "demo", "-o", str(demo)], check=True)
        save_view(demo / "mapping.mcap", work / "mapping.rrd", replay_dir=demo / "replay", force=True)
        shots.append(Shot("mapping", work / "mapping.rrd", 0.0, 45))
    if "navigation" in only:
        nav = work / "navigation.mcap"
        record(prepare(None, None, "nav_tour"), nav, progress=False, force=True)
        save_view(nav, work / "navigation.rrd", force=True)
        shots.append(Shot("navigation", work / "navigation.rrd", 5.0, 20))
    if "safety" in only:
        safety = write_safety_log(work / "safety.mcap")
        save_view(safety, work / "safety.rrd", force=True)
        shots.append(Shot("safety", work / "safety.rrd", 5.0, 15))
    if "real-bag" in only and (bags / "neato_drive_square").exists():
        save_view(bags / "neato_drive_square", work / "real-bag.rrd", force=True)
        shots.append(Shot("real-bag", work / "real-bag.rrd", 10.0, 20))
    if "diff" in only:
        shots.append(diff_shot(work))
    intel = bags.parent / "carmen" / "intel"
    if "slam-real" in only and intel.exists():
        shots.append(slam_shot(work, intel))
    return shots


def slam_shot(work: Path, log: Path) -> Shot:
    """The SLAM's replay of a real building's bag (the Intel lab), viewed over the bag with ``--replay``: the
    final map and the SLAM's path (blue) in the map frame, the bag's odometry (sky blue) and scans placed by the
    replay's map -> odom; the robot where the 3D camera starts."""
    from navlog.analysis.view import save_view
    from navlog.replay.session import run_replay

    out = work / "slam-real"
    run_replay(log, "mapping", out, overrides=["pose_source=slam", "lidar_mapper=off"], progress=False)
    save_view(log, work / "slam-real.rrd", replay_dir=out, force=True)
    return Shot("slam-real", work / "slam-real.rrd", 40.0, 40)  # sim_time: the bag starts at 32.9 s


def diff_shot(work: Path) -> Shot:
    """`navlog diff A B --rrd`: a 17 s teleop log's 2D mapping replayed on ground truth (A) and on the
    robot's drifting odometry (B); the 3D view must show A's blue and B's vermillion at its middle."""
    from navlog.analysis.diff import diff, save_overlay
    from navlog.analysis.diff.overlay import COLORS_DIFF
    from navlog.recorder.record import prepare, record
    from navlog.replay.session import run_replay

    log = work / "teleop.mcap"
    record(prepare("indoor_room", "go2", "teleop", seed=0), log, progress=False)
    for name, extra in (("diff-a", []), ("diff-b", ["pose_source=odom"])):
        run_replay(log, "mapping", work / name, overrides=["lidar_mapper=off", *extra], progress=False)
    save_overlay(diff(work / "diff-a", work / "diff-b"), work / "diff.rrd")
    return Shot("diff", work / "diff.rrd", 0.0, 15, (COLORS_DIFF["a"], COLORS_DIFF["b"]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demo", type=Path, help="a `navlog demo` output folder (default: run the demo)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    ap.add_argument("--shot", type=Path, default=ROOT.parent / "shared" / "tools" / "rerun-shot.sh")
    ap.add_argument("--bags", type=Path, default=ROOT.parent / "shared" / "external-data" / "bags")
    ap.add_argument("--only", nargs="+", choices=SHOTS, default=SHOTS, help="take these screenshots only")
    args = ap.parse_args()
    missing = prerequisites(args.shot)
    if missing:
        print(f"skipped: {missing}")
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    failed = 0
    with tempfile.TemporaryDirectory(prefix="navlog-view-shots-") as tmp:
        work = Path(tmp)
        for s in build_rrds(work, args.demo, args.bags, tuple(args.only)):
            raw = work / f"{s.name}.png"
            out = take(args.shot, s, raw)
            problems = check_png(raw, out, s.marks) if raw.is_file() else ["no screenshot written:\n" + out]
            if raw.is_file():
                shrink(raw, args.out / f"view-{s.name}.png")
            status = "ok" if not problems else "FAILED: " + "; ".join(problems)
            print(f"{s.name:<11} {args.out / f'view-{s.name}.png'}  {status}", flush=True)
            failed += bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
