"""The lap log of ``benchmarks/bench_slam_long.py``: the Intel bag forward, backward, forward (or forward only), as one
continuous log whose odometry composes the source's increments in each lap's order."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.geometry import planar_matrix
from navlog.replay.io.formats import open_log
from tests.replay.mapping.lap_logs import write_laps, yaw_of

pytestmark = pytest.mark.slow  # about 10-20 s: two logs of 55 000 and 165 000 messages read back


def _read(log):
    """Per topic: the log times; the odometry's (4x4 pose, vx, wz); the scans' ranges; the TF poses."""
    times: dict[str, list[int]] = {}
    odom, scans, tf = [], [], []
    with open_log(log) as reader:
        for env in reader.messages(["/scan", "/odom", "/tf", "/tf_static"]):
            times.setdefault(env.topic, []).append(env.time_ns)
            m = env.msg
            if env.topic == "/odom":
                p = m.pose.pose.position
                odom.append(
                    (
                        planar_matrix(p.x, p.y, yaw_of(m.pose.pose.orientation)),
                        m.twist.twist.linear.x,
                        m.twist.twist.angular.z,
                    )
                )
            elif env.topic == "/scan":
                scans.append(np.asarray(m.ranges))
            elif env.topic == "/tf":
                (ts,) = m.transforms
                tf.append(
                    planar_matrix(ts.transform.translation.x, ts.transform.translation.y, yaw_of(ts.transform.rotation))
                )
    return times, odom, scans, tf


def _increments(poses: list[np.ndarray]) -> np.ndarray:
    """(n - 1, 3) relative poses (x, y, yaw) of consecutive poses."""
    out = []
    for a, b in zip(poses[:-1], poses[1:], strict=True):
        d = np.linalg.solve(a, b)
        out.append((d[0, 3], d[1, 3], np.arctan2(d[1, 0], d[0, 0])))
    return np.array(out)


def test_laps_continue_the_odometry_with_the_source_increments_reversed(shared_dir, tmp_path):
    source = shared_dir / "external-data" / "carmen" / "intel"
    if not source.is_dir():
        pytest.skip(f"{source}: not in the external data")
    log, times = write_laps(source, tmp_path / "laps.mcap", 3)
    src_times, src_odom, src_scans, _ = _read(source)
    lap_times, lap_odom, lap_scans, lap_tf = _read(log)

    n = len(src_odom)  # 27362 odometry instants, 910 scans; the first and last instants hold a scan
    assert (n, len(src_scans)) == (27362, 910)
    assert len(lap_odom) == 3 * n - 2 and len(lap_scans) == 3 * 910 - 2  # a turning instant is not repeated
    assert len(lap_times["/tf_static"]) == 1
    for topic in ("/odom", "/tf", "/scan"):
        assert np.all(np.diff(lap_times[topic]) > 0), topic  # strictly increasing
    # the spacing: the source's gaps, then the same gaps in reverse order, then as they were
    gaps = np.diff(src_times["/odom"])
    assert np.array_equal(np.diff(lap_times["/odom"]), np.concatenate([gaps, gaps[::-1], gaps]))
    assert lap_times["/odom"][n - 1] == times[1].start  # the backward lap starts where the forward one ended

    # odometry: continuous, each lap composing the source's increments in its order
    src_inc = _increments([p for p, _, _ in src_odom])
    lap_inc = _increments([p for p, _, _ in lap_odom])
    # backward: the increment a -> b of the source, driven b -> a, is its inverse
    for k, inc in enumerate(src_inc[::-1]):
        inv = np.linalg.inv(planar_matrix(*inc))
        assert np.allclose(lap_inc[n - 1 + k, :2], inv[:2, 3], atol=1e-9)
        assert (
            abs(np.remainder(lap_inc[n - 1 + k, 2] - np.arctan2(inv[1, 0], inv[0, 0]) + np.pi, 2 * np.pi) - np.pi)
            < 1e-9
        )
    assert np.allclose(lap_inc[: n - 1], src_inc, atol=1e-9)
    assert np.allclose(lap_inc[2 * (n - 1) :], src_inc, atol=1e-9)
    # so the odometry comes back where it started, and /tf carries the same poses as /odom
    assert np.allclose(lap_odom[2 * (n - 1)][0], src_odom[0][0], atol=1e-9)
    assert all(np.allclose(a, b) for a, (b, _, _) in zip(lap_tf, lap_odom, strict=True))
    # driving back: the twist reversed; the scans taken where they were, in reverse order
    assert np.allclose([v for _, v, _ in lap_odom[n : 2 * n - 1]], [-v for _, v, _ in src_odom[-2::-1]])
    assert np.allclose([w for _, _, w in lap_odom[n : 2 * n - 1]], [-w for _, _, w in src_odom[-2::-1]])
    assert all(np.array_equal(a, b) for a, b in zip(lap_scans[910 : 2 * 910 - 1], src_scans[-2::-1], strict=True))


def test_forward_laps_repeat_the_tour_with_one_step_back_to_its_start(shared_dir, tmp_path):
    source = shared_dir / "external-data" / "carmen" / "intel"
    if not source.is_dir():
        pytest.skip(f"{source}: not in the external data")
    back = planar_matrix(1.2, -0.1, 0.35)  # from where the tour ends to where it starts
    log, times = write_laps(source, tmp_path / "laps.mcap", 2, back)
    src_times, src_odom, src_scans, _ = _read(source)
    lap_times, lap_odom, lap_scans, _ = _read(log)
    n = len(src_odom)
    assert len(lap_odom) == 2 * n and len(lap_scans) == 2 * 910  # every instant, twice
    assert np.all(np.diff(lap_times["/odom"]) > 0)
    step = int(np.median(np.diff(src_times["/odom"])))
    assert lap_times["/odom"][n] - lap_times["/odom"][n - 1] == step
    src_inc = _increments([p for p, _, _ in src_odom])
    lap_inc = _increments([p for p, _, _ in lap_odom])
    assert np.allclose(lap_inc[: n - 1], src_inc, atol=1e-9) and np.allclose(lap_inc[n:], src_inc, atol=1e-9)
    assert np.allclose(lap_inc[n - 1], (1.2, -0.1, 0.35), atol=1e-9)  # the one step between the laps
    assert np.allclose([v for _, v, _ in lap_odom[n:]], [v for _, v, _ in src_odom])  # driven forward again
    assert all(np.array_equal(a, b) for a, b in zip(lap_scans[910:], src_scans, strict=True))
