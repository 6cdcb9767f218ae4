"""Nav2's velocity smoother (``nav2_velocity_smoother``): its parameters, read and checked, and its algorithm.

The smoother limits the controller's commands (/cmd_vel_nav -> /cmd_vel_smoothed) to the velocity,
acceleration and deceleration bounds per axis, as Nav2 Jazzy's ``VelocitySmoother`` does. Axes are
(vx, vy, wz) for 3-entry limit vectors, (vx, vy, vz, wx, wy, wz) for 6 entries. Time is integer
nanoseconds; velocities are m/s and rad/s.

``VelocitySmoother`` holds the state of one smoother; every timer tick (``tick(now_ns)``):

1. no command received yet: nothing;
2. more than ``velocity_timeout`` since the last command: if the last smoothed command (before the
   deadband) is zero, or the smoother is already stopped, it stops and publishes nothing; otherwise
   the command becomes zero, so the output decelerates to zero and publishes that zero once;
3. the current velocity is the last smoothed command (``OPEN_LOOP``) or the mean of the odometry
   twists whose stamps lie within ``odom_duration`` of the newest (``CLOSED_LOOP``, ``OdomSmoother``);
4. ``smooth(command, current)``: the command is clamped per axis to [min_velocity, max_velocity];
   with ``scale_velocities`` every axis's change is scaled by one factor eta
   (``find_eta_constraint``: the most restrictive of the axes); each axis then moves from current by
   at most its bound (``apply_constraints``): +-max_accel / f when speeding up away from zero
   (``|cmd| >= |cur|`` and same sign), [max_decel / f, -max_decel / f] otherwise. The step is the
   nominal 1 / smoothing_frequency, never the measured time between ticks, as in Nav2;
5. that result is kept as the last command, then ``deadband_velocity`` zeroes the published copy
   only (``|v| < deadband``, strict), so a deadband never freezes the ramp.

The output's stamp is the command's stamp (plus the time since the last command with
``stamp_smoothed_velocity_with_smoothing_time``), its frame the command's frame. A command without
a stamp (a Twist, or a TwistStamped stamped 0) takes the time it was received, both for the timeout
(as Nav2) and as its stamp (Nav2 would publish stamp 0). NaN or infinite commands are refused
(``set_command`` returns False) and never reach the output.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from navlog.errors import ConfigError
from navlog.replay.limits import MAX_RATE_HZ
from navlog.replay.nav2.schema import ERROR, SectionReader, param

AXES = ("vx", "vy", "wz")
AXES_6DOF = ("vx", "vy", "vz", "wx", "wy", "wz")
_LIMITS = ("max_velocity", "min_velocity", "max_accel", "max_decel", "deadband_velocity")


@dataclass(frozen=True)
class VelocitySmootherParams:
    """``velocity_smoother`` node parameters (velocity vectors: vx, vy, wz or 6 axes)."""

    smoothing_frequency: float = param(20.0, gt=0.0, le=MAX_RATE_HZ)
    feedback: str = param("OPEN_LOOP", choices=("OPEN_LOOP", "CLOSED_LOOP"))
    scale_velocities: bool = False
    max_velocity: tuple[float, ...] = (0.5, 0.0, 2.5)
    min_velocity: tuple[float, ...] = (-0.5, 0.0, -2.5)
    max_accel: tuple[float, ...] = (2.5, 0.0, 3.2)
    max_decel: tuple[float, ...] = (-2.5, 0.0, -3.2)
    deadband_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    velocity_timeout: float = param(1.0, ge=0.0)
    odom_topic: str = "odom"
    odom_duration: float = param(0.1, gt=0.0)
    use_realtime_priority: bool = False
    enable_stamped_cmd_vel: bool = False
    stamp_smoothed_velocity_with_smoothing_time: bool = False
    use_sim_time: bool = False
    READ_ONLY: ClassVar[tuple[str, ...]] = ("use_realtime_priority", "use_sim_time")

    @property
    def axes(self) -> tuple[str, ...]:
        """The names of the axes the limit vectors give, in order."""
        return AXES_6DOF if len(self.max_velocity) == 6 else AXES


def _axis_name(i: int, n: int) -> str:
    names = AXES_6DOF if n == 6 else AXES
    return names[i] if i < len(names) else str(i)


def velocity_smoother_problems(vs: VelocitySmootherParams) -> Iterator[tuple[str | None, str]]:
    """(key, or None for the whole section; message) for every limit Nav2 refuses at configure time."""
    sizes = {k: len(getattr(vs, k)) for k in _LIMITS}
    for k, n in sizes.items():
        if n not in (3, 6):
            yield k, f"has {n} entries: expected 3 (vx, vy, wz) or 6"
    if len(set(sizes.values())) > 1:
        yield None, f"velocity vectors differ in length: {sizes}"
    for k, sign, word in (
        ("max_decel", -1, "<= 0"),
        ("max_accel", 1, ">= 0"),
        ("min_velocity", -1, "<= 0"),
        ("max_velocity", 1, ">= 0"),
    ):
        for i, v in enumerate(getattr(vs, k)):
            if v * sign < 0:
                yield k, f"{k}[{i}] ({_axis_name(i, sizes[k])}) = {v}: must be {word}; Nav2 rejects the configuration"
    for i, (lo, hi) in enumerate(zip(vs.min_velocity, vs.max_velocity, strict=False)):
        if lo > hi:
            yield "min_velocity", f"min_velocity[{i}] = {lo} is above max_velocity[{i}] = {hi}; Nav2 rejects it"


def read_velocity_smoother(r: SectionReader, params: dict, path: tuple) -> VelocitySmootherParams:
    """The node's parameters, with the vector lengths and signs Nav2 requires."""
    vs = r.read(VelocitySmootherParams, params, path)
    for key, message in velocity_smoother_problems(vs):
        r.add(ERROR, path + ((key,) if key else ()), message)
    return vs


# ------------------------------------------------------------------ the per-axis rules


def _bounds(v_curr: float, v_cmd: float, accel: float, decel: float, frequency: float) -> tuple[float, float]:
    """(lowest, highest) change of one axis in one step: accel when speeding up away from zero, else decel."""
    if abs(v_cmd) >= abs(v_curr) and v_curr * v_cmd >= 0.0:
        return -accel / frequency, accel / frequency
    return decel / frequency, -decel / frequency


def find_eta_constraint(v_curr: float, v_cmd: float, accel: float, decel: float, frequency: float) -> float:
    """The factor that brings this axis's change within its bound, or -1.0 when it already is (Nav2's eta)."""
    dv = v_cmd - v_curr
    lo, hi = _bounds(v_curr, v_cmd, accel, decel, frequency)
    if dv > hi:
        return hi / dv
    if dv < lo:
        return lo / dv
    return -1.0


def apply_constraints(v_curr: float, v_cmd: float, accel: float, decel: float, eta: float, frequency: float) -> float:
    """One axis's next velocity: current plus the eta-scaled change, clamped to the axis's own bound."""
    lo, hi = _bounds(v_curr, v_cmd, accel, decel, frequency)
    step = eta * (v_cmd - v_curr)
    return v_curr + (lo if step < lo else hi if hi < step else step)


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if hi < v else v


def _seconds_to_ns(s: float) -> int:
    """A duration in integer nanoseconds, truncated as ``rclcpp::Duration::from_seconds`` does."""
    return int(s * 1e9)


# ------------------------------------------------------------------ odometry feedback


class OdomSmoother:
    """Nav2's ``OdomSmoother``: the mean twist of the odometry whose stamps lie within ``duration_s`` of the newest.

    The mean is kept as a running sum (the oldest subtracted, the newest added), in Nav2's order, so
    it rounds as Nav2's does.
    """

    def __init__(self, duration_s: float, n_axes: int = 3) -> None:
        self.duration_ns = _seconds_to_ns(duration_s)
        self._history: deque[tuple[int, tuple[float, ...]]] = deque()
        self._sum = [0.0] * n_axes
        self.twist: tuple[float, ...] = (0.0,) * n_axes  # the smoothed twist (zero before any odometry)
        self.stamp_ns = 0

    def add(self, stamp_ns: int, values: Sequence[float]) -> None:
        """One odometry twist (the smoother's axes) stamped ``stamp_ns``."""
        while self._history and stamp_ns - self._history[0][0] > self.duration_ns:
            _, old = self._history.popleft()
            for i, v in enumerate(old):
                self._sum[i] -= v
        vals = tuple(float(v) for v in values)
        self._history.append((stamp_ns, vals))
        for i, v in enumerate(vals):
            self._sum[i] += v
        n = len(self._history)
        self.twist = tuple(s / n for s in self._sum)
        self.stamp_ns = stamp_ns


# ------------------------------------------------------------------ the smoother


class SmoothedCommand(NamedTuple):
    """One published output: its header stamp (ns), frame and velocities (after the deadband); immutable."""

    stamp_ns: int
    frame_id: str
    values: tuple[float, ...]


class VelocitySmoother:
    """The state of one Nav2 velocity smoother: the command, its time, the last smoothed command, odometry.

    Drive it with ``set_command`` (inputs), ``add_odometry`` (CLOSED_LOOP feedback) and ``tick`` (the
    timer at ``smoothing_frequency``); see the module docstring for the rule of one tick.
    """

    def __init__(self, params: VelocitySmootherParams) -> None:
        problems = [m for _, m in velocity_smoother_problems(params)]
        if problems:
            raise ConfigError(
                "velocity_smoother: invalid limits: " + "; ".join(problems) + " (fix the velocity_smoother parameters)"
            )
        self.params = params
        self.n_axes = len(params.max_velocity)
        self.open_loop = params.feedback == "OPEN_LOOP"
        self.timeout_ns = _seconds_to_ns(params.velocity_timeout)
        zero = (0.0,) * self.n_axes
        self.command: tuple[float, ...] | None = None  # the command to follow (None until the first one)
        self.command_stamp_ns = 0
        self.command_frame = ""
        self.last_command_time_ns = 0
        self.last_cmd: tuple[float, ...] = zero  # the last smoothed command, before the deadband
        self.stopped = False
        self.odom = OdomSmoother(params.odom_duration, self.n_axes)

    # -- inputs
    def set_command(self, values: Sequence[float], now_ns: int, stamp_ns: int = 0, frame_id: str = "") -> bool:
        """A new command received at ``now_ns`` (stamped ``stamp_ns``; 0 = unstamped); False if not finite."""
        vals = tuple(map(float, values))
        if len(vals) != self.n_axes:
            raise ValueError(f"velocity_smoother: a command of {len(vals)} axes, expected {self.n_axes}")
        if not all(map(math.isfinite, vals)):
            return False
        self.command = vals
        self.last_command_time_ns = stamp_ns if stamp_ns != 0 else now_ns
        self.command_stamp_ns = self.last_command_time_ns
        self.command_frame = frame_id
        return True

    def add_odometry(self, stamp_ns: int, values: Sequence[float]) -> None:
        """An odometry twist (the smoother's axes), used as the current velocity in CLOSED_LOOP."""
        self.odom.add(stamp_ns, values)

    # -- the algorithm
    def current(self) -> tuple[float, ...]:
        """The velocity the next step starts from: the last smoothed command or the smoothed odometry."""
        return self.last_cmd if self.open_loop else self.odom.twist

    def smooth(self, command: Sequence[float], current: Sequence[float]) -> tuple[float, ...]:
        """One step from ``current`` toward ``command``: velocity clamp, eta scaling, accel/decel bounds."""
        p, f = self.params, self.params.smoothing_frequency
        cmd = [_clamp(float(v), lo, hi) for v, lo, hi in zip(command, p.min_velocity, p.max_velocity, strict=True)]
        eta = 1.0
        if p.scale_velocities:
            for i, c in enumerate(cmd):
                e = find_eta_constraint(current[i], c, p.max_accel[i], p.max_decel[i], f)
                if e > 0.0 and abs(1.0 - e) > abs(1.0 - eta):
                    eta = e
        return tuple(
            [
                apply_constraints(cur, c, accel, decel, eta, f)
                for cur, c, accel, decel in zip(current, cmd, p.max_accel, p.max_decel, strict=False)
            ]
        )

    def deadband(self, values: Sequence[float]) -> tuple[float, ...]:
        """The published copy: each axis below its deadband (strictly) becomes 0."""
        return tuple([0.0 if abs(v) < db else v for v, db in zip(values, self.params.deadband_velocity, strict=True)])

    def tick(self, now_ns: int) -> SmoothedCommand | None:
        """The timer: the command to publish at ``now_ns``, or None (no command yet, or stopped after a timeout)."""
        if self.command is None:
            return None
        since = now_ns - self.last_command_time_ns
        stamp = self.command_stamp_ns + (since if self.params.stamp_smoothed_velocity_with_smoothing_time else 0)
        frame = self.command_frame
        if since > self.timeout_ns:
            if self.stopped or all(v == 0.0 for v in self.last_cmd):
                self.stopped = True
                return None
            self.command = (0.0,) * self.n_axes
            self.command_stamp_ns = now_ns
            self.command_frame = ""
        self.stopped = False
        self.last_cmd = self.smooth(self.command, self.current())
        return SmoothedCommand(stamp, frame, self.deadband(self.last_cmd))
