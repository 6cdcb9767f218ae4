"""Each comparator on synthetic inputs with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.analysis.diff import (
    DiffTolerances,
    FieldTolerance,
    GridTolerance,
    MetricTolerance,
    PathTolerance,
    PointsTolerance,
    TrajectoryTolerance,
    TwistTolerance,
    Verdict,
    compare_grids,
    compare_metric_values,
    compare_plans,
    compare_points,
    compare_trajectories,
    compare_twists,
    field_differences,
    parse_tolerances,
)
from navlog.analysis.diff.metric_values import direction
from navlog.analysis.metrics import Trajectory
from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.occupancy_map import OccupancyMap

# ---------------------------------------------------------------- grids


def _grid(occupied_cells, *, n=10, res=0.1, origin=(0.0, 0.0, 0.0)):
    data = np.zeros((n, n), dtype=np.int8)
    for r, c in occupied_cells:
        data[r, c] = 100
    return OccupancyMap(data, res, origin)


def test_three_cells_of_a_hundred_changed_is_three_percent():
    a = _grid([(0, 0)])
    b = _grid([(0, 0), (0, 1), (0, 2), (0, 3)])
    check = compare_grids("map", a, b, GridTolerance())
    assert check.verdict is Verdict.CHANGED
    assert check.values["cells"] == 100 and check.values["changed_cells"] == 3
    assert check.values["changed_share"] == pytest.approx(0.03)
    assert check.values["iou"] == pytest.approx(0.25)  # 1 shared of 4 occupied
    assert check.values["hausdorff_m"] == pytest.approx(0.3)  # (0, 3) is 3 cells of 0.1 m from (0, 0)
    loose = compare_grids("map", a, b, GridTolerance(changed_share=0.03, hausdorff_m=0.3))
    assert loose.verdict is Verdict.WITHIN
    assert compare_grids("map", a, _grid([(0, 0)]), GridTolerance()).verdict is Verdict.EQUAL


def test_unknown_counts_as_a_class_and_occupancy_values_use_map_server_thresholds():
    a = _grid([])
    b = _grid([])
    b.data[5, 5] = -1  # free -> unknown
    b.data[6, 6] = 50  # 0.50: neither free (< 0.196) nor occupied (> 0.65): unknown
    b.data[7, 7] = 10  # still free
    check = compare_grids("map", a, b, GridTolerance(changed_share=0.0))
    assert check.values["changed_cells"] == 2
    assert check.verdict is Verdict.CHANGED
    assert check.values["hausdorff_m"] == 0.0  # no occupied cell either side


def test_grids_of_other_resolution_and_origin_are_compared_on_a_common_canvas():
    a = OccupancyMap(np.zeros((20, 20), dtype=np.int8), 0.05, (0.0, 0.0, 0.0))
    b = OccupancyMap(np.zeros((10, 10), dtype=np.int8), 0.1, (0.0, 0.0, 0.0))
    same = compare_grids("map", a, b, GridTolerance(changed_share=0.0, hausdorff_m=0.0))
    assert same.verdict is Verdict.WITHIN and same.values["changed_cells"] == 0
    shifted = OccupancyMap(np.zeros((20, 20), dtype=np.int8), 0.05, (0.5, 0.0, 0.0))
    check = compare_grids("map", a, shifted, GridTolerance())
    # union 1.5 x 1.0 m = 30 x 20 cells; 10 columns known on one side only, twice
    assert check.values["cells"] == 600 and check.values["changed_cells"] == 400


def test_a_map_that_lost_every_obstacle_is_infinitely_far():
    check = compare_grids("map", _grid([(1, 1)]), _grid([]), GridTolerance(changed_share=1.0))
    assert math.isinf(check.values["hausdorff_m"]) and check.verdict is Verdict.CHANGED


# ---------------------------------------------------------------- plans


def test_paths_a_tenth_of_a_metre_apart():
    x = np.linspace(0.0, 2.0, 21)
    a = np.stack([x, np.zeros_like(x)], axis=1)
    b = a + [0.0, 0.1]
    check = compare_plans("/plan", a, b, PathTolerance())
    assert check.values["max_hausdorff_m"] == pytest.approx(0.1)
    assert check.values["max_endpoint_m"] == pytest.approx(0.1)
    assert check.values["max_length_change_m"] == pytest.approx(0.0)
    assert check.verdict is Verdict.CHANGED  # default 0.05 m
    assert compare_plans("/plan", a, b, PathTolerance(hausdorff_m=0.1, endpoint_m=0.1)).verdict is Verdict.WITHIN
    shorter = compare_plans("/plan", a, a[:11], PathTolerance(hausdorff_m=5, endpoint_m=5))
    assert shorter.values["max_length_change_m"] == pytest.approx(-1.0)
    assert shorter.verdict is Verdict.CHANGED


def test_a_plan_that_now_fails_is_changed_whatever_the_tolerance():
    a = np.array([[0.0, 0.0], [1.0, 0.0]])
    huge = PathTolerance(hausdorff_m=1e9, length_m=1e9, endpoint_m=1e9, cost_rtol=1e9)
    check = compare_plans("/plan", a, np.zeros((0, 2)), huge)
    assert check.verdict is Verdict.CHANGED and check.values["success_changed"] == 1


def test_a_nan_in_a_plan_is_a_difference_whatever_the_tolerance():
    a = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    b = a.copy()
    b[1, 1] = np.nan
    huge = PathTolerance(hausdorff_m=1e9, length_m=1e9, endpoint_m=1e9, cost_rtol=1e9)
    for x, y in ((a, b), (b, a), (b, b.copy())):
        check = compare_plans("/plan", x, y, huge)
        assert check.verdict is Verdict.CHANGED and check.values["nonfinite_pairs"] == 1
        assert "NaN or infinite" in check.detail
    assert "nonfinite_pairs" not in compare_plans("/plan", a, a + 0.01, huge).values


# ---------------------------------------------------------------- velocity commands


def test_one_command_off_by_five_centimetres_per_second():
    a = np.zeros((10, 6))
    a[:, 0] = 0.2
    b = a.copy()
    b[4, 0] += 0.05
    check = compare_twists("/cmd_vel", a, b, TwistTolerance())
    assert check.values["max.linear.x"] == pytest.approx(0.05)
    assert check.values["rms.linear.x"] == pytest.approx(0.05 / math.sqrt(10))
    assert check.values["rms.angular.z"] == 0.0
    assert check.values["beyond_tolerance"] == 1
    assert check.verdict is Verdict.CHANGED
    assert compare_twists("/cmd_vel", a, b, TwistTolerance(max_abs=0.06)).verdict is Verdict.WITHIN
    assert compare_twists("/cmd_vel", a, a[:9], TwistTolerance(max_abs=1.0)).verdict is Verdict.CHANGED


# ---------------------------------------------------------------- trajectories


def _line(n=50, dx=0.0):
    t = np.arange(n, dtype=np.int64) * 100_000_000
    pos = np.stack([np.linspace(0, 4.9, n) + dx, np.zeros(n), np.zeros(n)], axis=1)
    return Trajectory(t, pos, np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)))


def test_a_trajectory_shifted_by_two_centimetres_has_ate_two_centimetres():
    check = compare_trajectories("trajectory.tum", _line(), _line(dx=0.02), TrajectoryTolerance())
    assert check.values["ate_m"] == pytest.approx(0.02)
    assert check.values["rpe_m"] == pytest.approx(0.0, abs=1e-12)  # a constant shift keeps relative motion
    assert check.values["pairs"] == 50
    assert check.verdict is Verdict.CHANGED  # default 0.01 m
    assert compare_trajectories("t", _line(), _line(dx=0.02), TrajectoryTolerance(ate_m=0.03)).verdict is Verdict.WITHIN
    assert compare_trajectories("t", _line(), _line(), TrajectoryTolerance()).verdict is Verdict.EQUAL


# ---------------------------------------------------------------- point maps


def test_a_point_map_shifted_by_one_centimetre():
    g = np.arange(5, dtype=np.float64)
    a = np.stack(np.meshgrid(g, g, g), axis=-1).reshape(-1, 3)  # 125 points 1 m apart
    b = a + [0.01, 0.0, 0.0]
    check = compare_points("map.pcd", a, b, PointsTolerance())
    assert check.values["chamfer_m"] == pytest.approx(0.01)
    assert check.values["hausdorff_m"] == pytest.approx(0.01)
    assert check.values["beyond_tau"] == 0
    assert check.verdict is Verdict.WITHIN
    tight = compare_points("map.pcd", a, b, PointsTolerance(tau_m=0.005))
    assert tight.values["beyond_share"] == pytest.approx(1.0) and tight.verdict is Verdict.CHANGED


# ---------------------------------------------------------------- metrics.json


def test_lower_ate_is_improved_and_lower_f1_is_regressed():
    a = {"inputs": {"replay": "a/"}, "trajectory": {"ate": {"translation_m": {"rmse": 0.05}}}, "map_2d": {"f1": 0.9}}
    b = {"inputs": {"replay": "b/"}, "trajectory": {"ate": {"translation_m": {"rmse": 0.03}}}, "map_2d": {"f1": 0.8}}
    checks = {c.name: c for c in compare_metric_values("metrics.json", a, b, MetricTolerance())}
    assert checks["metrics.json:trajectory.ate.translation_m.rmse"].verdict is Verdict.IMPROVED
    assert checks["metrics.json:map_2d.f1"].verdict is Verdict.REGRESSED
    assert checks["metrics.json:map_2d.f1"].values["delta"] == pytest.approx(-0.1)
    assert len(checks) == 2  # the inputs section (paths) is not compared
    within = compare_metric_values("m", {"map_2d": {"f1": 0.9}}, {"map_2d": {"f1": 0.9000001}}, MetricTolerance())
    assert [c.verdict for c in within] == [Verdict.WITHIN]


@pytest.mark.parametrize(
    ("key", "want"),
    [
        ("map_2d.precision", "higher"),
        ("map_2d.iou_tau", "higher"),
        ("map_3d.accuracy.0.05", "higher"),
        ("map_3d.visible.completeness.0.02", "higher"),
        ("trajectory.rpe.rotation_deg.median", "lower"),
        ("map_2d.hausdorff_m", "lower"),
        ("map_2d.counts.est_occupied", "equal"),
        ("trajectory.ate.pairs", "equal"),
    ],
)
def test_metric_directions(key, want):
    assert direction(key) == want


# ---------------------------------------------------------------- any other message, field by field


def _scan(ranges):
    msg = m.deserialize(
        m.serialize(
            m.msg_class(m.LASER_SCAN)(
                header=m.header(5, "laser"),
                angle_min=0.0,
                angle_max=1.0,
                angle_increment=0.1,
                time_increment=0.0,
                scan_time=0.1,
                range_min=0.1,
                range_max=6.0,
                ranges=np.asarray(ranges, dtype=np.float32),
                intensities=np.zeros(0, dtype=np.float32),
            ),
            m.LASER_SCAN,
        ),
        m.LASER_SCAN,
    )
    return msg


def test_fields_within_max_of_atol_and_rtol():
    a = _scan([1.0, 2.0, np.inf, np.nan, 4.0])
    b = _scan([1.0, 2.0, np.inf, np.nan, 4.5])
    (d,) = list(field_differences(a, b))
    assert d.path == "ranges[4]" and d.abs_diff == pytest.approx(0.5)
    assert list(field_differences(a, b, FieldTolerance(atol=0.5))) == []
    assert len(list(field_differences(a, b, FieldTolerance(rtol=0.1)))) == 1  # 0.1 * 4.5 = 0.45 < 0.5
    assert list(field_differences(a, b, FieldTolerance(rtol=0.12))) == []  # 0.12 * 4.5 = 0.54 >= 0.5
    assert list(field_differences(a, b, ignore=["ranges"])) == []
    c = _scan([1.0, 2.0, 5.0, np.nan, 4.0])  # inf -> finite is a difference whatever the tolerance
    assert [d.path for d in field_differences(a, c, FieldTolerance(rtol=1.0))] == ["ranges[2]"]
    d2 = _scan([1.0])
    assert [d.path for d in field_differences(a, d2)] == ["ranges.length"]


# ---------------------------------------------------------------- tolerances


def test_tolerance_keys_are_checked_with_a_suggestion():
    tol = parse_tolerances(["grid.changed_share=0.01", "twist.max_abs=1e-6"])
    assert tol.grid.changed_share == 0.01 and tol.twist.max_abs == 1e-6
    assert tol.grid.hausdorff_m == DiffTolerances().grid.hausdorff_m
    with pytest.raises(ConfigError, match="did you mean 'grid.changed_share'"):
        parse_tolerances(["grid.changed_shar=0.01"])
    with pytest.raises(ConfigError, match="not a number"):
        parse_tolerances(["grid.changed_share=lots"])
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        parse_tolerances(["grid.changed_share"])
    with pytest.raises(ConfigError, match=">= 0"):
        parse_tolerances(["twist.max_abs=-1"])
