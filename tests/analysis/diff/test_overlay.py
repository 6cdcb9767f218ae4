"""``navlog diff --rrd``: what the overlay draws, in which colours, and how its blueprint lays it out.

Two hand-built replay folders: a 4 x 4 m canvas at 0.1 m whose middle 2 x 2 m are known, B with one
more occupied cell and one more free cell; a straight 10 s trajectory that B leaves after 5 s (0.1 m/s sideways); commands
that B caps at 0.25 m/s; a plan B moves 0.5 m north.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from navlog.analysis.diff.overlay import (
    COLORS_DIFF,
    DIVERGENCE_M,
    build_overlay,
    overlay_blueprint,
    save_overlay,
)
from navlog.analysis.diff.result import DiffReport
from navlog.analysis.view.blueprint import CAMERA_BACK_M, CAMERA_UP_M
from navlog.analysis.view.context import COLORS
from navlog.replay import messages as m
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.map_server import save_map
from navlog.replay.io.tum import write_tum
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.executor import Envelope

S = 1_000_000_000
BLUE, VERMILLION, YELLOW = (0, 114, 178), (213, 94, 0), (240, 228, 66)


def _path(t: int, y: float):
    pose_stamped = m.msg_class(m.POSE_STAMPED)
    poses = [pose_stamped(header=m.header(t, "map"), pose=m.pose((x, y, 0.0), (0, 0, 0, 1))) for x in (0.0, 1.0, 2.0)]
    return m.msg_class(m.PATH)(header=m.header(t, "map"), poses=poses)


def _replay(folder: Path, *, candidate: bool) -> Path:
    folder.mkdir()
    (folder / "manifest.json").write_text('{"outputs": {}}', encoding="utf-8")  # a replay folder to input_kind
    data = np.full((40, 40), -1, dtype=np.int8)
    data[10:30, 10:30] = 0  # known: x and y in [-1, 1)
    data[10:30, 10] = 100  # the west wall
    data[29, 29] = -1  # an unknown corner cell
    if candidate:
        data[20, 15] = 100  # one more occupied cell
        data[29, 29] = 0  # one more free cell
    save_map(OccupancyMap(data, 0.1, (-2.0, -2.0, 0.0)), folder / "map.yaml")
    t = np.arange(11, dtype=np.int64) * S
    xy = np.stack([np.linspace(-1.0, 1.0, 11), np.zeros(11)], axis=1)
    if candidate:
        xy[6:, 1] = 0.1 * np.arange(1, 6)  # 0.1, 0.2, ... m north from 6 s
    pos = np.concatenate([xy, np.zeros((11, 1))], axis=1)
    write_tum(folder / "trajectory.tum", t, pos, np.tile([0.0, 0.0, 0.0, 1.0], (11, 1)))
    vx = np.minimum(np.linspace(0.0, 0.4, 9), 0.25 if candidate else 1.0)
    with McapLogWriter(folder / "replay.mcap") as w:
        for i, v in enumerate(vx):
            w.write(Envelope("/cmd_vel", m.TWIST, i * S, m.twist(float(v), 0.0, 0.1)))
        w.write(Envelope("/plan", m.PATH, 2 * S, _path(2 * S, 0.5 if candidate else 0.0)))
    return folder


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> DiffReport:
    root = tmp_path_factory.mktemp("overlay")
    a, b = _replay(root / "a", candidate=False), _replay(root / "b", candidate=True)
    return DiffReport(a=str(a), b=str(b), kind="replay", checks=())


@pytest.fixture(scope="module")
def plan(report):
    import rerun as rr

    rec = rr.RecordingStream("navlog_diff_test")
    rec.memory_recording()
    return build_overlay(report, rec)


def test_a_and_b_keep_the_colours_of_navlog_view(plan):
    # blue (an estimate), vermillion (the local plan), yellow (the scan): Okabe-Ito, from view.context
    assert COLORS_DIFF["a"] == COLORS["estimate2"] == BLUE
    assert COLORS_DIFF["b"] == COLORS["local_plan"] == VERMILLION
    assert COLORS_DIFF["changed"] == COLORS["scan"] == YELLOW
    side = {"a": BLUE, "b": VERMILLION}
    for s, color in side.items():
        for ent in (f"{s}/map", f"{s}/trajectory", f"top/{s}/trajectory", f"{s}/plans/plan", f"plots/cmd_vel/vx/{s}"):
            assert plan.colors[ent] == color, ent
    for ent in ("diff/map_changed", "diff/divergence", "top/diff/divergence", "plots/trajectory/distance"):
        assert plan.colors[ent] == YELLOW, ent
    assert plan.colors["plots/cmd_vel/vx/diff"] == plan.colors["plots/cmd_vel/wz/diff"] == YELLOW


def test_the_camera_starts_on_the_first_divergence_of_the_trajectories(plan):
    # B is 0.1 m north of A at 6 s, where A stands at x = 0.2 heading east
    assert DIVERGENCE_M < 0.1
    assert plan.focus == "first divergence of the trajectories"
    assert plan.camera_target == pytest.approx((0.2, 0.0, 0.0))
    assert plan.camera_position == pytest.approx((0.2 - CAMERA_BACK_M, 0.0, CAMERA_UP_M))


def test_plots_carry_units_and_ranges_that_hold_their_data(plan):
    by_title = {p.title: p for p in plan.plots}
    assert sorted(by_title) == [
        "/cmd_vel forward vx (m/s)",
        "/cmd_vel turn wz (rad/s)",
        "trajectory distance |B - A| (m)",
    ]
    vx = by_title["/cmd_vel forward vx (m/s)"]
    assert vx.entities == ("/plots/cmd_vel/vx/a", "/plots/cmd_vel/vx/b", "/plots/cmd_vel/vx/diff")
    lo, hi = vx.y_range  # A reaches 0.4 m/s, B - A goes down to -0.15 m/s
    assert lo < -0.15 and 0.4 < hi < 0.5
    lo, hi = by_title["trajectory distance |B - A| (m)"].y_range
    assert lo == 0.0 and 0.5 < hi < 0.6  # B ends 0.5 m from A


def test_the_top_down_view_opens_on_the_known_cells(plan):
    # cells 10..29 of 40 are known: the view shows them plus 0.5 m (5 px), not the unknown canvas
    assert plan.top_bounds == pytest.approx((5.0, 35.0, 5.0, 35.0))


def test_the_blueprint_puts_3d_and_top_down_above_plots_and_report(plan):
    bp = overlay_blueprint(plan)
    layout = bp.root_container
    (top, bottom) = layout.contents
    names = [v.name for v in top.contents]
    assert names[0].startswith("3D") and names[1].startswith("top-down")
    plots, text = bottom.contents
    assert text.name == "diff report"
    assert len(plots.contents) == 3
    # without 3D or top-down content (a safety replay: commands only) the plots take the window
    commands_only = type(plan)(colors={"plots/cmd_vel/vx/a": BLUE}, plots=plan.plots[:1])
    assert not commands_only.has_3d()
    grid, text = overlay_blueprint(commands_only).root_container.contents
    assert [v.name for v in grid.contents] == [plan.plots[0].title] and text.name == "diff report"


def test_the_saved_file_holds_the_drawn_entities(report, tmp_path):
    from tests.analysis.view.rrd import read_rrd, verify

    out = save_overlay(report, tmp_path / "diff.rrd")
    assert verify(out).returncode == 0
    data = read_rrd(out)
    assert {"/a/map", "/b/map", "/diff/map_changed", "/top/map", "/diff/divergence", "/a/plans/plan"} <= set(data)
    (batch,) = data["/diff/map_changed"]["static"]
    changed = np.array(batch.column("Points3D:positions").to_pylist()[0])
    # the new occupied cell at (-0.45, 0.05) and the corner cell at (0.95, 0.95), lifted over A's and B's
    assert changed[:, :2].round(2).tolist() == [[-0.45, 0.05], [0.95, 0.95]]
    assert changed[:, 2] == pytest.approx([0.02, 0.02])  # float32 in the file


def test_without_trajectories_the_camera_starts_on_the_first_plan_that_moved(report, tmp_path):
    import shutil

    import rerun as rr

    for side in ("a", "b"):  # the commands and plans of a planner replay, no map, no trajectory
        (tmp_path / side).mkdir()
        shutil.copy(Path(getattr(report, side)) / "replay.mcap", tmp_path / side / "replay.mcap")
    rec = rr.RecordingStream("navlog_diff_test")
    rec.memory_recording()
    plan = build_overlay(DiffReport(a=str(tmp_path / "a"), b=str(tmp_path / "b"), kind="replay", checks=()), rec)
    assert plan.focus == "first /plan that moved" and plan.camera_target == pytest.approx((0.0, 0.0, 0.0))
    assert plan.has_3d() and not any(e.startswith("top/") for e in plan.colors)
