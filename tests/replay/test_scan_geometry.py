"""LaserScan geometry: a scan whose angle_increment is 0, of the wrong sign, or whose beam count the angle
limits do not give is a counted skip in every consumer and a FAIL in ``navlog check``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from navlog.analysis.check import Status, check_log
from navlog.replay import messages as m
from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Envelope
from navlog.replay.scan_geometry import INCONSISTENT, NOT_FINITE, WRONG_SIGN, ZERO_INCREMENT, geometry_fault
from navlog.replay.session import run_replay

PI = math.pi


def test_the_geometry_of_real_drivers_passes_and_broken_fields_are_named():
    # navlog's recorder: 360 beams over a full turn, angle_max one increment past the last beam
    assert geometry_fault(-PI, PI, 2 * PI / 360, 360) is None
    # REP 117 / urg_node: angle_max at the last beam; a mirrored laser sweeping clockwise
    assert geometry_fault(-2.0, 2.0, 4.0 / 720, 721) is None
    assert geometry_fault(2.0, -2.0, -4.0 / 720, 721) is None
    assert geometry_fault(0.5, 0.5, 0.01, 1) is None
    assert geometry_fault(-PI, PI, 0.0, 360) == ZERO_INCREMENT
    assert geometry_fault(-PI, PI, -2 * PI / 360, 360) == WRONG_SIGN
    assert geometry_fault(-PI, PI, 2 * PI / 360, 180) == INCONSISTENT  # half the beams: every bearing wrong
    assert geometry_fault(-PI, PI, 2 * PI / 360, 362) == INCONSISTENT
    assert geometry_fault(-PI, PI, 1e-320, 360) == INCONSISTENT
    assert geometry_fault(-PI, math.nan, 0.01, 360) == NOT_FINITE


def _rewrite_scans(src: Path, dst: Path, **fields: float) -> int:
    """``src`` with the given fields of every other /scan replaced; returns the number of scans changed."""
    n = i = 0
    with McapLogWriter(dst) as w, open_log(src) as r:
        for env in r.messages():
            if env.topic == "/scan" and (i := i + 1) % 2 == 0:
                msg = (
                    m.deserialize(bytes(env.msg), env.typename) if isinstance(env.msg, bytes | memoryview) else env.msg
                )
                for k, v in fields.items():
                    setattr(msg, k, v)
                env = Envelope(env.topic, env.typename, env.time_ns, msg)
                n += 1
            w.write(env)
    return n


@pytest.fixture(scope="module")
def zero_increment(teleop_log, tmp_path_factory) -> tuple[Path, int]:
    path = tmp_path_factory.mktemp("scan_geometry") / "zero.mcap"
    return path, _rewrite_scans(teleop_log, path, angle_increment=0.0)


def test_navlog_check_fails_a_log_of_unusable_scans(zero_increment):
    path, scans = zero_increment
    result = check_log(path)
    check = next(c for c in result.checks if c.name == "scan_values" and c.subject == "/scan")
    assert check.status is Status.FAIL and result.status is Status.FAIL
    assert check.numbers["scans_with_bad_geometry"] == scans
    assert ZERO_INCREMENT in check.message


def test_the_mapper_and_slam_skip_and_count_unusable_scans(zero_increment, tmp_path):
    path, scans = zero_increment
    res = run_replay(path, "mapping", tmp_path / "m", overrides=["lidar_mapper=off"], progress=False)
    assert res.manifest["skipped"][f"/scan: {ZERO_INCREMENT}"] > 0.9 * scans
    res = run_replay(
        path, "mapping", tmp_path / "s", overrides=["pose_source=slam", "lidar_mapper=off"], progress=False
    )
    assert res.manifest["skipped"][f"/scan: {ZERO_INCREMENT}"] > 0.9 * scans


def test_amcl_and_the_collision_monitor_skip_and_count_unusable_scans(teleop_log, tmp_path):
    from navlog.recorder.world import write_world_map

    write_world_map("indoor_room", tmp_path / "map.yaml", margin=0.0)
    path = tmp_path / "sign.mcap"
    scans = _rewrite_scans(teleop_log, path, angle_increment=-2 * PI / 360)
    overrides = [f"map={tmp_path / 'map.yaml'}", "nav2_params=amcl_go2"]
    res = run_replay(path, "localization", tmp_path / "l", overrides=overrides, progress=False)
    assert sum(v for k, v in res.manifest["skipped"].items() if k.endswith(WRONG_SIGN)) > 0.9 * scans
    res = run_replay(path, "safety", tmp_path / "c", remap={"/cmd_vel_nav": "/cmd_vel"}, progress=False)
    assert sum(v for k, v in res.manifest["skipped"].items() if k.endswith(WRONG_SIGN)) >= scans
    json.dumps(res.manifest, allow_nan=False)


def test_a_costmap_scan_source_skips_and_counts_an_unusable_scan():
    from navlog.replay.nav2 import load_nav2_params
    from navlog.replay.nav2.costmap.observation import ObservationSourceParams
    from navlog.replay.nodes.costmap import CostmapNode

    nav2 = load_nav2_params(Path(__file__).parents[2] / "config" / "nav2" / "nav_go2.yaml")
    node = CostmapNode(nav2.local_costmap, "local_costmap")
    node.tf.add(node.params.global_frame, "laser", 0, (1.0, 2.0, 0.0), (0, 0, 0, 1), static=True)
    scan = m.msg_class(m.LASER_SCAN)(
        header=m.header(0, "laser"),
        angle_min=-PI,
        angle_max=PI,
        angle_increment=2 * PI / 4,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.1,
        range_max=10.0,
        ranges=[1.0, 1.0, 1.0, 1.0],
        intensities=[],
    )
    sp = ObservationSourceParams(topic="/scan", data_type="LaserScan")
    obs = node._observation("scan", 0, scan, sp, 0)
    assert obs is not None and obs.points[0, :2].tolist() == pytest.approx([0.0, 2.0])  # 1 m behind, at (1, 2)
    scan.angle_increment = -2 * PI / 4
    assert node._observation("scan", 0, scan, sp, 0) is None
    scan.angle_increment, scan.ranges = 2 * PI / 4, [1.0] * 8
    assert node._observation("scan", 0, scan, sp, 0) is None
    assert node.skipped == {f"scan: {WRONG_SIGN}": 1, f"scan: {INCONSISTENT}": 1}


def test_scan_angles_keep_a_bounded_number_of_angle_sets():
    import types

    from navlog.replay.scan_geometry import ANGLE_SETS_KEPT, ScanAngles

    angles = ScanAngles()
    for k in range(1000):  # every scan a different start angle: a log written that way, or a hostile one
        lo = -PI + k * 1e-6
        msg = types.SimpleNamespace(
            angle_min=lo, angle_max=lo + PI, angle_increment=PI / 8, ranges=[1.0] * 9, range_min=0.1, range_max=5.0
        )
        got = angles(msg)
        assert got is not None and got[0] == lo and got[-1] == pytest.approx(lo + PI)
        assert len(angles._cache) <= ANGLE_SETS_KEPT
