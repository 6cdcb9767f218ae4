"""Nav2's velocity smoother: Nav2's own unit-test vectors (test_velocity_smoother.cpp) and their tolerances."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.velocity_smoother import (
    OdomSmoother,
    VelocitySmoother,
    VelocitySmootherParams,
    apply_constraints,
    find_eta_constraint,
)

F = 20.0  # Nav2's default smoothing_frequency, used by every unit test
ACCEL, DECEL = 0.1, -1.0  # dv 0.005 per step speeding up, 0.05 slowing down
MS = 1_000_000


# ------------------------------------------------------------------ findEtaConstraint


@pytest.mark.parametrize(
    ("v_curr", "v_cmd"),
    [
        (1.0, 1.0),
        (-1.0, -1.0),
        (0.5, 0.504),
        (0.5, 0.46),
        (0.0, 0.004),
        (0.04, 0.0),
        (-0.5, -0.504),
        (-0.5, -0.46),
        (0.0, -0.004),
        (-0.04, 0.0),
        (-0.02, 0.02),
        (0.02, -0.02),
    ],
)
def test_eta_in_range_is_minus_one(v_curr, v_cmd):
    assert find_eta_constraint(v_curr, v_cmd, ACCEL, DECEL, F) == -1


@pytest.mark.parametrize(
    ("v_curr", "v_cmd", "eta"),
    [
        (0.5, 1.5, 0.005),  # positive to positive, accelerating
        (1.5, 0.5, 0.05),  # positive to positive, decelerating
        (0.0, 1.0, 0.005),
        (1.0, 0.0, 0.05),
        (-0.5, -1.5, 0.005),
        (-1.5, -0.5, 0.05),
        (0.0, -1.0, 0.005),
        (-1.0, 0.0, 0.05),
        (-0.2, 0.8, 0.05),  # through zero: decelerating bound
        (0.2, -0.8, 0.05),
    ],
)
def test_eta_faster_than_limit(v_curr, v_cmd, eta):
    assert find_eta_constraint(v_curr, v_cmd, ACCEL, DECEL, F) == eta


# ------------------------------------------------------------------ applyConstraints


def test_apply_constraints_vectors():
    assert apply_constraints(1.0, 1.0, 1.5, -2.0, 1.0, F) == 1.0
    assert apply_constraints(0.5, 0.55, 1.5, -2.0, 1.0, F) == 0.55
    assert apply_constraints(0.5, 0.45, 1.5, -2.0, 1.0, F) == 0.45
    assert apply_constraints(1.0, 2.0, 1.5, -2.0, 1.0, F) == pytest.approx(1.075, abs=0.01)
    assert apply_constraints(1.0, 2.0, 1.5, -2.0, 0.075, F) == pytest.approx(1.075, abs=0.01)
    assert apply_constraints(0.5, 0.55, 1.5, -2.0, 0.075, F) == pytest.approx(0.503, abs=0.01)
    assert apply_constraints(0.5, 0.55, 1.5, -2.0, 0.075, F) == pytest.approx(0.50375, abs=1e-12)
    # angular, eta 0.75: Nav2 asserts 1.075 +- 0.95; the value is 0.8 + 0.75 * 0.2
    assert apply_constraints(0.8, 1.0, 3.2, -3.2, 0.75, F) == pytest.approx(1.075, abs=0.95)
    assert apply_constraints(0.8, 1.0, 3.2, -3.2, 0.75, F) == pytest.approx(0.95, abs=1e-12)


def _ramp(init, target, n):
    v, out = init, []
    for _ in range(n):
        v = apply_constraints(v, target, ACCEL, DECEL, 1.0, F)
        out.append(v)
    return out


@pytest.mark.parametrize(
    ("init", "target", "dv"),
    [
        (1.0, 2.0, ACCEL / 20.0),
        (0.0, 2.0, ACCEL / 20.0),
        (-1.0, -2.0, ACCEL / 20.0),
        (0.0, -2.0, ACCEL / 20.0),
        (2.0, 1.0, -DECEL / 20.0),
        (2.0, 0.0, -DECEL / 20.0),
        (-2.0, -1.0, -DECEL / 20.0),
        (-2.0, 0.0, -DECEL / 20.0),
    ],
    ids=[
        "pos-pos-accel",
        "zero-pos-accel",
        "neg-neg-accel",
        "zero-neg-accel",
        "pos-pos-decel",
        "pos-zero-decel",
        "neg-neg-decel",
        "neg-zero-decel",
    ],
)
def test_ramp_moves_by_the_bound_each_step_then_holds(init, target, dv):
    steps = int(abs(target - init) / dv)
    sign = 1.0 if target > init else -1.0
    ramp = _ramp(init, target, steps + 1)
    for i, v in enumerate(ramp[:steps], start=1):
        assert v == pytest.approx(init + sign * i * dv, abs=0.001)
    assert ramp[steps - 1] == pytest.approx(target, abs=0.001)
    assert ramp[steps] == pytest.approx(target, abs=0.001)


@pytest.mark.parametrize(("init", "target"), [(-1.0, 2.0), (1.0, -2.0)], ids=["neg-to-pos", "pos-to-neg"])
def test_ramp_through_zero_decelerates_then_accelerates(init, target):
    dv_accel, dv_decel = ACCEL / 20.0, -DECEL / 20.0
    sign = 1.0 if target > 0 else -1.0
    to_zero = int(abs(init) / dv_decel)
    from_zero = int(abs(target) / dv_accel)
    ramp = _ramp(init, target, to_zero + from_zero + 1)
    for i, v in enumerate(ramp[: to_zero + from_zero], start=1):
        if v * sign > 0:
            assert v == pytest.approx(sign * (i - to_zero) * dv_accel, abs=0.001)
        else:
            assert v == pytest.approx(init + sign * i * dv_decel, abs=0.001)
    assert ramp[-2] == pytest.approx(target, abs=0.001)
    assert ramp[-1] == pytest.approx(target, abs=0.001)
    assert ramp[to_zero - 1] == pytest.approx(0.0, abs=1e-12)  # the deceleration reaches zero in to_zero steps


# ------------------------------------------------------------------ the timer


def _run(smoother, ticks, period_ms=50):
    """Published values of vx at ticks 1..ticks (Nav2's timer fires one period after activation)."""
    out = []
    for k in range(1, ticks + 1):
        cmd = smoother.tick(k * period_ms * MS)
        if cmd is not None:
            out.append(cmd.values)
    return out


def test_open_loop_timer_nav2_vector():
    """openLoopTestTimer: scale on, deadband 0.2 on vx, cmd 1.0 once, 1.5 s of timer."""
    s = VelocitySmoother(VelocitySmootherParams(scale_velocities=True, deadband_velocity=(0.2, 0.0, 0.0)))
    assert s.set_command((1.0, 0.0, 0.0), now_ns=0)
    vx = [v[0] for v in _run(s, 30)]
    assert 19 < len(vx) < 30
    assert vx[-1] == 0.0
    assert next(v for v in vx if v != 0) > 0.2
    assert all(v <= 0.5 for v in vx)
    # the exact sequence: 0.125 (under the deadband), 0.25, 0.375, then the 0.5 limit until the 1 s
    # timeout; then zero is commanded: 0.375, 0.25, 0.125 (under the deadband), 0.0, and silence
    assert vx == pytest.approx([0.0, 0.25, 0.375] + [0.5] * 17 + [0.375, 0.25, 0.0, 0.0], abs=1e-12)


def test_deadband_applies_to_the_published_copy_only():
    s = VelocitySmoother(VelocitySmootherParams(deadband_velocity=(0.2, 0.0, 0.0)))
    s.set_command((1.0, 0.0, 0.0), now_ns=0)
    first = s.tick(50 * MS)
    assert first is not None and first.values == (0.0, 0.0, 0.0)
    assert s.last_cmd == (0.125, 0.0, 0.0)  # the ramp goes on under the deadband (Nav2 #3690, #3699)
    assert s.tick(100 * MS).values[0] == 0.25


def test_timeout_ramps_to_zero_then_stops_publishing():
    s = VelocitySmoother(VelocitySmootherParams(deadband_velocity=(0.2, 0.0, 0.0)))
    s.set_command((1.0, 0.0, 0.0), now_ns=0)
    _run(s, 20)  # up to 1.0 s: not yet timed out (the rule is strictly longer than velocity_timeout)
    assert s.last_cmd == (0.5, 0.0, 0.0)
    tail = [s.tick(k * 50 * MS) for k in range(21, 27)]
    assert [t.values[0] for t in tail if t is not None] == pytest.approx([0.375, 0.25, 0.0, 0.0], abs=1e-12)
    assert tail[4:] == [None, None] and s.stopped
    # a new command wakes it up
    s.set_command((0.1, 0.0, 0.0), now_ns=1400 * MS)
    out = s.tick(1400 * MS)
    assert out is not None and not s.stopped
    assert (out.values[0], s.last_cmd[0]) == (0.0, pytest.approx(0.1))  # 0.1 is under the 0.2 deadband


def test_scale_velocities_keeps_the_direction():
    p = VelocitySmootherParams(scale_velocities=True)
    s = VelocitySmoother(p)
    assert s.smooth((0.5, 0.0, 1.0), (0.0, 0.0, 0.0)) == pytest.approx((0.08, 0.0, 0.16), abs=1e-12)
    unscaled = VelocitySmoother(replace(p, scale_velocities=False))
    assert unscaled.smooth((0.5, 0.0, 1.0), (0.0, 0.0, 0.0)) == pytest.approx((0.125, 0.0, 0.16), abs=1e-12)


def test_reversing_uses_deceleration_and_velocity_is_clamped():
    s = VelocitySmoother(VelocitySmootherParams())
    assert s.smooth((-0.3, 0.0, 0.0), (0.3, 0.0, 0.0))[0] == pytest.approx(0.175, abs=1e-12)
    assert s.smooth((0.4, 0.0, -9.0), (0.4, 0.0, -2.5)) == (0.4, 0.0, -2.5)  # wz clamped to min_velocity


def test_nan_command_is_refused():
    s = VelocitySmoother(VelocitySmootherParams())
    assert not s.set_command((math.nan, 0.0, 0.0), now_ns=0)
    assert not s.set_command((0.0, 0.0, math.inf), now_ns=0)
    assert s.tick(50 * MS) is None  # still no command


def test_stamps_follow_the_command():
    p = VelocitySmootherParams(stamp_smoothed_velocity_with_smoothing_time=True)
    s = VelocitySmoother(p)
    s.set_command((0.2, 0.0, 0.0), now_ns=7 * MS, stamp_ns=5 * MS, frame_id="base_link")
    out = s.tick(50 * MS)
    assert (out.stamp_ns, out.frame_id) == (50 * MS, "base_link")  # 5 ms + 45 ms since the command
    plain = VelocitySmoother(replace(p, stamp_smoothed_velocity_with_smoothing_time=False))
    plain.set_command((0.2, 0.0, 0.0), now_ns=7 * MS, stamp_ns=5 * MS, frame_id="base_link")
    assert plain.tick(50 * MS).stamp_ns == 5 * MS
    plain.set_command((0.2, 0.0, 0.0), now_ns=60 * MS)  # unstamped: its receive time
    assert plain.tick(100 * MS).stamp_ns == 60 * MS


# ------------------------------------------------------------------ closed loop


def test_odom_smoother_averages_the_last_odom_duration():
    odom = OdomSmoother(0.1)
    for k, vx in enumerate((0.0, 0.1, 0.2)):
        odom.add(k * 50 * MS, (vx, 0.0, 0.0))
    assert odom.twist[0] == pytest.approx(0.1, abs=1e-12)
    odom.add(150 * MS, (0.3, 0.0, 0.0))  # stamp 0 is now older than 0.1 s: dropped; 50 ms is kept
    assert odom.twist[0] == pytest.approx(0.2, abs=1e-12)


def test_closed_loop_starts_from_odometry():
    s = VelocitySmoother(VelocitySmootherParams(feedback="CLOSED_LOOP"))
    s.set_command((0.5, 0.0, 0.0), now_ns=0)
    assert s.tick(50 * MS).values[0] == pytest.approx(0.125)  # no odometry yet: from rest
    s.add_odometry(60 * MS, (0.2, 0.0, 0.0))
    assert s.tick(100 * MS).values[0] == pytest.approx(0.325, abs=1e-12)  # 0.2 + 2.5 / 20, not 0.25


def test_closed_loop_ramp_each_step_under_the_accel_bound():
    """approxClosedLoopTestTimer without ROS: odometry repeats the last output at 100 Hz."""
    s = VelocitySmoother(VelocitySmootherParams(feedback="CLOSED_LOOP"))
    for i in range(30):
        s.add_odometry(i * 10 * MS, (0.0, 0.0, 0.0))
    s.set_command((1.0, 0.0, 0.0), now_ns=0)
    out: list[float] = []
    for t in range(0, 1501, 10):
        s.add_odometry(t * MS, (out[-1] if out else 0.0, 0.0, 0.0))
        if t % 50 == 0 and t > 0 and (cmd := s.tick(t * MS)) is not None:
            out.append(cmd.values[0])
    assert 19 < len(out) < 30
    assert out[-1] == 0.0
    assert all(b - a < 0.126 for a, b in zip(out, out[1:], strict=False))
    assert all(v <= 0.5 for v in out)


# ------------------------------------------------------------------ parameters Nav2 refuses


def _errors(body: str) -> dict[str, str]:
    p = parse_nav2_text("velocity_smoother:\n  ros__parameters:\n" + body)
    out: dict[str, str] = {}
    for e in p.errors:
        key = e.path.removeprefix("velocity_smoother.ros__parameters").lstrip(".")
        out[key] = f"{out[key]} | {e.message}" if key in out else e.message
    return out


def test_invalid_params_size_and_feedback():
    assert "has 2 entries" in _errors("    max_velocity: [0.0, 0.0]\n")["max_velocity"]
    assert "LAWLS" in _errors("    feedback: LAWLS\n")["feedback"]


def test_invalid_params_accel_decel_and_velocities():
    errors = _errors(
        "    max_velocity: [-10.0, -10.0, -10.0]\n"
        "    min_velocity: [10.0, 10.0, 10.0]\n"
        "    max_accel: [-10.0, -10.0, -10.0]\n"
        "    max_decel: [10.0, 10.0, 10.0]\n"
    )
    assert "must be >= 0" in errors["max_velocity"]
    assert "must be >= 0" in errors["max_accel"]
    assert "must be <= 0" in errors["max_decel"]
    assert "must be <= 0" in errors["min_velocity"]
    assert "min_velocity[0] = 10.0 is above max_velocity[0] = -10.0" in errors["min_velocity"]
    assert set(errors) == {"max_velocity", "min_velocity", "max_accel", "max_decel"}
    assert _errors("    max_velocity: [0.45, 0.0, 1.2]\n    min_velocity: [-0.2, 0.0, -1.2]\n") == {}


def test_smoother_refuses_invalid_limits():
    with pytest.raises(ConfigError, match=r"max_decel\[0\] \(vx\) = 2.5: must be <= 0"):
        VelocitySmoother(VelocitySmootherParams(max_decel=(2.5, 0.0, -3.2)))
