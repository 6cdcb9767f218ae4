"""scripts/carmen_to_bag.py: a corrected CARMEN log as the external data's carmen/ bags are made."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from navlog.replay.geometry import se2_compose
from navlog.replay.session import run_replay
from tests.replay.mapping.planar_logs import planar_tum, read_bag

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "carmen_to_bag.py"
spec = importlib.util.spec_from_file_location("carmen_to_bag", SCRIPT)
carmen = sys.modules[spec.name] = importlib.util.module_from_spec(spec)  # (its dataclass looks itself up)
spec.loader.exec_module(carmen)


def flaser(ranges, x, y, yaw, t) -> str:
    return f"FLASER {len(ranges)} {' '.join(f'{r:g}' for r in ranges)} {x} {y} {yaw} {x} {y} {yaw} {t} host {t}\n"


def odom(x, y, yaw, t) -> str:
    return f"ODOM {x} {y} {yaw} 0 0 0 {t} host {t}\n"


RANGES = [2.0, 3.0, 50.0, 49.95, 4.0, 50.0]  # 50: the no-return code; 49.95 within 0.1 m below it


def small_log() -> str:
    return (
        "# a corrected log\nPARAM robot_frontlaser_offset 0.0 nohost 0\n"
        + odom(0, 0, 0, 0.5)
        + flaser(RANGES, 1.0, 2.0, 0.5, 1.0)
        + odom(1.0, 2.0, 0.5, 0)  # the reset to the corrected pose, stamped 0
        + odom(1.0 + 0.4 * math.cos(0.5), 2.0 + 0.4 * math.sin(0.5), 0.6, 1.5)  # the wheels: 0.4 m on, turning 0.1
        + flaser(RANGES, 1.5, 2.2, 0.55, 2.0)  # corrected: elsewhere
        + odom(1.5, 2.2, 0.55, 7.9)  # a reset whose timestamp is garbage
        + flaser(RANGES, 2.5, 2.2, 0.55, 1.9)  # no wheel data since: the corrected step; its time goes back
    )


def test_wheel_steps_are_chained_from_the_resets_and_the_corrected_step_fills_a_gap() -> None:
    log = carmen.parse_carmen(small_log().splitlines())
    assert log.stamps.tolist() == [1_000_000_000, 2_000_000_000, 2_010_000_000]  # 10 ms after the one before
    np.testing.assert_allclose(log.odometry[0], [0, 0, 0])
    np.testing.assert_allclose(log.odometry[1], [0.4, 0.0, 0.1], atol=1e-12)  # the wheels' own step, not 0.54 m
    step = carmen._relative(log.corrected[1], log.corrected[2])  # 1 m straight on in the corrected frame
    np.testing.assert_allclose(step, [1.0 * math.cos(0.55), -1.0 * math.sin(0.55), 0.0], atol=1e-12)
    np.testing.assert_allclose(log.odometry[2], se2_compose(log.odometry[1], step), atol=1e-12)
    assert carmen.no_return_code(log.ranges) == 50.0


def test_a_file_without_times_is_stamped_a_scan_a_second() -> None:
    lines = "".join(flaser(RANGES, x, 0, 0, 4.29497e09) for x in range(3))  # the infinite corridor's: all 2^32 - 1
    assert carmen.parse_carmen(lines.splitlines()).stamps.tolist() == [10**9, 2 * 10**9, 3 * 10**9]


def test_the_bag_holds_the_scans_odometry_and_reference_and_maps(tmp_path: Path) -> None:
    log_path = tmp_path / "tiny-corrected.log"
    log_path.write_text(small_log())
    assert carmen.main([str(log_path), "--out", str(tmp_path / "out")]) == 0
    folder = tmp_path / "out" / "external-data" / "carmen"
    scans, odom_at = read_bag(folder / "tiny")
    assert sorted(scans) == [1_000_000_000, 2_000_000_000, 2_010_000_000]
    angles, ranges, _, range_max = scans[1_000_000_000]
    assert ranges.tolist()[:2] == [2.0, 3.0] and np.isinf(ranges[[2, 3, 5]]).all() and ranges[4] == 4.0
    assert range_max == pytest.approx(49.9) and angles[1] - angles[0] == pytest.approx(math.pi / 6, rel=1e-6)
    np.testing.assert_allclose(odom_at[2_000_000_000], [0.4, 0.0, 0.1], atol=1e-6)
    stamps, reference = planar_tum(folder / "tiny.reference.tum")
    np.testing.assert_allclose(reference[1], [1.5, 2.2, 0.55], atol=1e-6)
    assert stamps.tolist() == sorted(scans)
    # navlog replays it: the SLAM maps the three scans
    run = run_replay(folder / "tiny", "mapping", tmp_path / "slam", overrides=["pose_source=slam", "lidar_mapper=off"])
    assert (tmp_path / "slam" / "map.yaml").is_file() and run is not None
    # a second conversion into the same folder is refused, and a line that is not one is named
    assert carmen.main([str(log_path), "--out", str(tmp_path / "out")]) == 2
    bad = tmp_path / "bad-corrected.log"
    bad.write_text(small_log() + "FLASER 3 1 2\n")
    assert carmen.main([str(bad), "--out", str(tmp_path / "other")]) == 2
    assert not (tmp_path / "other" / "external-data" / "carmen" / "bad").exists()
