"""Nav2's MPPI ``Optimizer``: the control sequence, its noise, the motion model, and one cycle's update.

``eval_control`` is one cycle, as Nav2's ``evalControl``:

1. **optimize**, ``iteration_count`` times: noise (one normal draw per axis and per batch row and
   time step, ``vx_std``/``vy_std``/``wz_std``, vy for Omni only) is added to the control sequence;
   the motion model clamps each noised control to what ``ax_max``/``ax_min``/``az_max`` allow from
   the one before (``predict``); the velocities are integrated into poses; every critic adds its
   cost; the sequence becomes the softmax-weighted (``temperature``, with the ``gamma`` control
   cost) mean of the noised sequences and is clipped by ``applyControlSequenceConstraints``;
2. **fallback**: when the CostCritic finds every trajectory in collision, the optimizer resets and
   retries; after ``retry_attempt_limit`` retries the cycle raises ``NoValidControl``;
3. the sequence is smoothed (Savitzky-Golay, with the 4 last commands as history), its element 0
   (1 when the control period equals ``model_dt``: the sequence is then shifted every cycle) is the
   command.

Noise comes from ``np.random.default_rng(setup.seed)`` only: the same seed, plan, poses and costmaps
give the same commands bit for bit. With ``setup.background`` (a runner of the execution layer) the
next cycle's noise is drawn beside the caller once a cycle has used the last: the same draws in the
same order, waited for before use. The batch's arrays are float32 as Nav2's, shaped (batch,
time_steps), kept from cycle to cycle. One round's rollouts run as numba kernels (compiled on first
use, cached on disk): ``noised_rollouts`` (noised controls, ``predict``'s clamp, the yaws), then the
cos and sin of the yaws by NumPy and ``positions``; ``predict`` and ``integrate`` run the same kernels.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.base import ControllerSetup, NoValidControl, Pose2D, Twist2D
from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
from navlog.replay.nav2.controllers.mppi.critics import Critic
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.costmap.grid import CostmapGrid

F32 = np.float32  # the batch's arrays are float32, as Nav2's
LANES = 16  # rollouts clamped side by side (``_clamp_rows``)
SAVITZKY_GOLAY = np.array([-21.0, 14.0, 39.0, 54.0, 59.0, 54.0, 39.0, 14.0, -21.0]) / 231.0


def _clamp_rows(cv, state, a, up, down):
    """Axis ``a`` of every rollout clamped from column 0 of ``state`` on (see ``clamp_rollouts``), ``LANES``
    rollouts side by side so that their step-after-step chains overlap in the CPU (3x faster than one
    rollout after the other; the same operations on each value)."""
    nb, nt = cv.shape[1], cv.shape[2]
    last = np.empty(LANES)
    for i0 in range(0, nb, LANES):
        n = min(LANES, nb - i0)
        for k in range(n):
            last[k] = float(state[a, i0 + k, 0])
        for j in range(1, nt):
            for k in range(n):
                i, before = i0 + k, last[k]
                if a == 2 or before > 0:
                    lo, hi = before + down, before + up
                else:
                    lo, hi = before - up, before - down
                cv[a, i, j - 1] = min(max(float(cv[a, i, j - 1]), lo), hi)
                state[a, i, j] = cv[a, i, j - 1]
                last[k] = float(cv[a, i, j - 1])


def _heading_row(state, traj, i, yaw0, dt):
    """One rollout's yaw (``traj[2]``): ``yaw0`` plus the float32 running sum of ``wz * dt``, as NumPy's cumsum."""
    total = yaw0 - yaw0  # float32 zero
    for j in range(state.shape[2]):
        total += state[2, i, j] * dt
        traj[2, i, j] = yaw0 + total


def positions(state, cos, sin, traj, x0, y0, dt, holonomic):
    """Every rollout's x, y (``traj[0]``, ``traj[1]``), to be compiled: float32 running sums of the velocities
    turned by ``cos``/``sin`` (column j: of the yaw of step j-1, column 0: of the robot's)."""
    for i in range(state.shape[1]):
        sx = sy = x0 - x0  # float32 zero
        for j in range(state.shape[2]):
            vx, c, s = state[0, i, j], cos[i, j], sin[i, j]
            dx, dy = vx * c, vx * s
            if holonomic:
                vy = state[1, i, j]
                dx, dy = dx - vy * s, dy + vy * c
            sx += dx * dt
            sy += dy * dt
            traj[0, i, j] = x0 + sx
            traj[1, i, j] = y0 + sy


def clamp_rollouts(cv, state, axes, ups, downs):
    """``Optimizer.predict``'s clamp, to be compiled: per axis in ``axes`` and per rollout, each control
    clamped to [last + down, last + up] (reverse: [last - up, last - down]; axis 2, wz, always the
    former) from the one before, the bounds in float64 and the control stored as float32; ``state``
    takes the clamped controls one step later."""
    for k in range(axes.shape[0]):
        a = axes[k]
        _clamp_rows(cv, state, a, ups[a], downs[a])


def headings(state, traj, yaw0, dt):
    """Every rollout's yaw (``traj[2]``), to be compiled (see ``_heading_row``)."""
    for i in range(state.shape[1]):
        _heading_row(state, traj, i, yaw0, dt)


def noised_rollouts(u, noises, speed, axes, ups, downs, yaw0, dt, cv, state, traj):
    """One optimizer round's batch, to be compiled: the noised controls ``cv = u + noises``, clamped by
    the motion model from ``speed`` (``state``: column 0 the speed, then the clamped controls; an axis not
    clamped stays 0), and the rollouts' yaw ``traj[2]``."""
    nb, nt = noises.shape[1], noises.shape[2]
    for a in range(3):
        for i in range(nb):
            for j in range(nt):
                cv[a, i, j] = u[a, j] + noises[a, i, j]
                state[a, i, j] = 0.0
            state[a, i, 0] = speed[a]
    clamp_rollouts(cv, state, axes, ups, downs)
    headings(state, traj, yaw0, dt)


@functools.cache
def compiled_rollouts() -> dict[str, Callable[..., None]]:
    """``clamp_rollouts``, ``headings``, ``positions`` and ``noised_rollouts`` compiled by numba (on first
    use; cached on disk); one arithmetic path per rollout."""
    return compile_together(
        globals(), (_clamp_rows, _heading_row, clamp_rollouts, headings, positions, noised_rollouts)
    )


class Optimizer:
    """Nav2's MPPI ``Optimizer``: the control sequence, its noise, the motion model, the critics.

    ``eval_control`` is one cycle (see the module docstring). ``set_noises`` replaces the noise
    (tests inject fixed noise); otherwise noise is drawn at reset and, with ``regenerate_noises``,
    again after each use.
    """

    def __init__(self, params: MPPIParams, setup: ControllerSetup, critics: list[Critic[Any]]) -> None:
        self.p = params
        self.critics = critics
        self.rng = np.random.default_rng(setup.seed)
        self.holonomic = params.motion_model == "Omni"
        period = 1.0 / setup.controller_frequency
        if period + 1e-6 < params.model_dt:
            self.shift = False
        elif abs(period - params.model_dt) < 1e-6:
            self.shift = True
        else:
            raise ConfigError(
                f"MPPI: the controller period 1/controller_frequency = {period:g} s is longer than model_dt "
                f"{params.model_dt:g} s; Nav2 refuses it ('Controller period more then model dt'): set "
                f"controller_frequency to {1.0 / params.model_dt:g} Hz or model_dt to {period:g}"
            )
        self.set_speed_limit(0.0, True)
        self._fail_count = 0
        self._injected: np.ndarray | None = None
        self._background = setup.background
        self._next_noises: Callable[[], None] | None = None  # the wait of the noise being drawn
        self._buffers: dict[str, np.ndarray] = {}
        self._path_facts: tuple[int | None, np.ndarray | None] = (None, None)
        self.last_cmd: Twist2D = (0.0, 0.0, 0.0)
        self.reset()

    # -------------------------------------------------------- state
    def reset(self) -> None:
        """Zero control sequence and history, fresh noise (Nav2's ``reset``; speed limits are kept)."""
        b, t = self.p.batch_size, self.p.time_steps
        self.u = np.zeros((3, t), dtype=F32)  # vx, vy, wz
        self.history = np.zeros((4, 3), dtype=F32)
        self.costs = np.zeros(b, dtype=F32)
        if self.p.open_loop:
            self.last_cmd = (0.0, 0.0, 0.0)
        if self._injected is None:
            self._await_noises()
            self.noises = np.zeros((3, b, t), dtype=F32)
            self._draw_noises(self.noises)
        self.trajectories = np.zeros((3, b, t), dtype=F32)

    def _draw_noises(self, out: np.ndarray) -> None:
        """Fill ``out`` (3, batch, time_steps) with the next draws: vx then wz (then vy, Omni) times their std."""
        for axis, std in ((0, self.p.vx_std), (2, self.p.wz_std)) + (((1, self.p.vy_std),) if self.holonomic else ()):
            self.rng.standard_normal(out=out[axis], dtype=F32)
            out[axis] *= F32(std)

    def _regenerate_noises(self) -> None:
        """The next noise, drawn now or (with ``setup.background``) beside the caller until it is used."""
        noises = self.noises  # drawn in place: the cycle has used it, the next waits for the draw
        if self._background is None:
            self._draw_noises(noises)
        else:
            self._next_noises = self._background(lambda: self._draw_noises(noises))

    def _await_noises(self) -> None:
        """Wait for the noise being drawn, if any (before it is used or the generator draws again)."""
        if self._next_noises is not None:
            wait, self._next_noises = self._next_noises, None
            wait()

    def set_noises(self, vx: np.ndarray, vy: np.ndarray, wz: np.ndarray) -> None:
        """Use this noise (each (batch, time_steps)) from now on, instead of drawn noise."""
        shape = (self.p.batch_size, self.p.time_steps)
        self._await_noises()
        self._injected = np.stack([np.broadcast_to(np.asarray(a, dtype=F32), shape) for a in (vx, vy, wz)])
        self.noises = self._injected

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2's ``setSpeedLimit``: 0 restores the limits, else scale vx, vy and wz by pct/100 or limit/vx_max."""
        p = self.p
        if limit == 0.0:
            ratio = 1.0
        elif percentage:
            ratio = limit / 100.0
        else:
            ratio = limit / p.vx_max
        self.vx_max, self.vx_min = p.vx_max * ratio, p.vx_min * ratio
        self.vy_max, self.wz_max = p.vy_max * ratio, p.wz_max * ratio

    # -------------------------------------------------------- one cycle
    def eval_control(
        self,
        pose: Pose2D,
        speed: Twist2D,
        path: np.ndarray,
        goal: tuple[float, float],
        costmap: CostmapGrid | None,
        goal_xy_tolerance: float | None = None,
    ) -> Twist2D:
        """The command for this cycle (Nav2's ``evalControl``); NoValidControl after the retries."""
        speed = self.last_cmd if self.p.open_loop else speed
        self._path_facts = (None, None)
        while True:
            data = self._optimize(pose, speed, path, goal, costmap, goal_xy_tolerance)
            if not self._fallback(data.fail_flag):
                break
        self._smooth()
        self.last_cmd = self._command()
        if self.shift:
            self._shift()
        return self.last_cmd

    def _command(self) -> Twist2D:
        """The sequence's element 0, or 1 when it shifts every cycle (Nav2's ``getControlFromSequenceAsTwist``)."""
        k = 1 if self.shift else 0
        return float(self.u[0, k]), float(self.u[1, k]) if self.holonomic else 0.0, float(self.u[2, k])

    def _shift(self) -> None:
        """Nav2's ``shiftControlSequence``: one step earlier, the last control repeated."""
        self.u[:, :-1] = self.u[:, 1:].copy()
        self.u[:, -1] = self.u[:, -2]

    def _optimize(
        self,
        pose: Pose2D,
        speed: Twist2D,
        path: np.ndarray,
        goal: tuple[float, float],
        costmap: CostmapGrid | None,
        goal_xy_tolerance: float | None,
    ) -> CriticData:
        """``iteration_count`` rounds of noise, rollouts, critics and the control sequence's update."""
        data = None
        self.costs = np.zeros(self.p.batch_size, dtype=F32)
        for _ in range(self.p.iteration_count):
            cv, state, self.trajectories = self._noised_controls(pose, speed)
            data = CriticData(
                pose=pose,
                goal=goal,
                path=path,
                vx=state[0],
                vy=state[1],
                wz=state[2],
                x=self.trajectories[0],
                y=self.trajectories[1],
                yaw=self.trajectories[2],
                model_dt=self.p.model_dt,
                costmap=costmap,
                goal_xy_tolerance=goal_xy_tolerance,
                holonomic=self.holonomic,
                costs=self.costs,
                furthest=self._path_facts[0],
                path_valid=self._path_facts[1],
            )
            for critic in self.critics:
                critic.score(data)
            # as Nav2, the furthest reached path point and the path's validity are found once a cycle
            self._path_facts = (data.furthest, data.path_valid)
            self._update_control_sequence(cv)
        assert data is not None
        return data

    def _noised_controls(self, pose: Pose2D, speed: Twist2D) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(cv, state, trajectories): the noised controls clamped by ``predict``, the state velocities
        (column 0 = speed) and the poses they integrate to, in one compiled pass (``noised_rollouts``)."""
        self._await_noises()
        cv, state, traj = (self._buffer(name, self.noises.shape) for name in ("cv", "state", "traj"))
        axes, ups, downs = self._clamp_limits()
        dt = F32(self.p.model_dt)
        compiled_rollouts()["noised_rollouts"](
            self.u, self.noises, self._speed(speed), axes, ups, downs, F32(pose[2]), dt, cv, state, traj
        )
        self._positions(pose, state, traj)
        if self.p.regenerate_noises and self._injected is None:
            self._regenerate_noises()
        return cv, state, traj

    def _buffer(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A float32 array kept from cycle to cycle (its contents overwritten by each): no fresh pages a cycle."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = self._buffers[name] = np.empty(shape, dtype=F32)
        return buf

    def _speed(self, speed: Twist2D) -> np.ndarray:
        return np.array([speed[0], speed[1] if self.holonomic else 0.0, speed[2]], dtype=F32)

    def _positions(self, pose: Pose2D, state: np.ndarray, traj: np.ndarray) -> None:
        """x, y of the rollouts (``traj[0:2]``) from their velocities and yaw (``traj[2]``): step j moves along
        the yaw of step j-1 (step 0 along the robot's), the cos and sin by NumPy (vectorised), float32."""
        cos, sin = self._buffer("cos", traj[2].shape), self._buffer("sin", traj[2].shape)
        cos[:, 0], sin[:, 0] = math.cos(pose[2]), math.sin(pose[2])
        np.cos(traj[2, :, :-1], out=cos[:, 1:])
        np.sin(traj[2, :, :-1], out=sin[:, 1:])
        x0, y0, dt = F32(pose[0]), F32(pose[1]), F32(self.p.model_dt)
        compiled_rollouts()["positions"](state, cos, sin, traj, x0, y0, dt, self.holonomic)

    def _clamp_limits(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(axes, ups, downs): the clamped axes and each axis's velocity change a step allows (float64)."""
        p, dt = self.p, self.p.model_dt
        limits: list[tuple[int, float, float]] = [(0, p.ax_max, p.ax_min), (2, p.az_max, -p.az_max)]
        if self.holonomic:
            limits.insert(1, (1, p.ay_max, p.ay_min))
        ups, downs = np.zeros(3), np.zeros(3)
        for a, amax, amin in limits:
            ups[a], downs[a] = amax * dt, amin * dt
        return np.array([a for a, _, _ in limits], dtype=np.int64), ups, downs

    def predict(self, cv: np.ndarray, speed: Twist2D) -> np.ndarray:
        """Nav2's ``MotionModel::predict``: each control clamped to the acceleration limits from the one
        before, starting from ``speed``; ``cv`` (3, B, T) is clamped in place, the state (3, B, T) returned.
        """
        state = np.zeros_like(cv)
        state[:, :, 0] = self._speed(speed)[:, None]
        compiled_rollouts()["clamp_rollouts"](cv, state, *self._clamp_limits())
        return state

    def integrate(self, pose: Pose2D, state: np.ndarray) -> np.ndarray:
        """Nav2's ``integrateStateVelocities``: (x, y, yaw) (3, B, T); step j moves along the yaw of step j-1."""
        traj = np.empty_like(state)
        compiled_rollouts()["headings"](state, traj, F32(pose[2]), F32(self.p.model_dt))
        self._positions(pose, state, traj)
        return traj

    def _update_control_sequence(self, cv: np.ndarray) -> None:
        """Nav2's ``updateControlSequence``: control cost, softmax over the batch, weighted mean, constraints."""
        p = self.p
        axes = (0, 1, 2) if self.holonomic else (0, 2)
        std = (p.vx_std, p.vy_std, p.wz_std)
        for a in axes:
            self.costs += p.gamma / std[a] ** 2 * ((cv[a] - self.u[a]) @ self.u[a])
        w = np.exp(-(self.costs - self.costs.min()) / p.temperature)
        w /= w.sum()
        for a in axes:
            self.u[a] = w @ cv[a]
        self.apply_constraints()

    def apply_constraints(self) -> None:
        """Nav2's ``applyControlSequenceConstraints``: clip to the speed limits, then the acceleration
        limits along the sequence, then (Ackermann) no turn tighter than min_turning_r."""
        p, dt, u = self.p, self.p.model_dt, self.u
        if self.holonomic:
            np.clip(u[1], -self.vy_max, self.vy_max, out=u[1])
        np.clip(u[0], self.vx_min, self.vx_max, out=u[0])
        np.clip(u[2], -self.wz_max, self.wz_max, out=u[2])
        vx, vy, wz = u[0].tolist(), u[1].tolist(), u[2].tolist()
        for i in range(1, len(vx)):
            vx[i] = _accel_clamp(vx[i], vx[i - 1], p.ax_max * dt, p.ax_min * dt)
            wz[i] = min(max(wz[i], wz[i - 1] - p.az_max * dt), wz[i - 1] + p.az_max * dt)
            if self.holonomic:
                vy[i] = _accel_clamp(vy[i], vy[i - 1], p.ay_max * dt, p.ay_min * dt)
        u[0], u[1], u[2] = vx, vy, wz
        if p.motion_model == "Ackermann":
            r = p.ackermann.min_turning_r
            with np.errstate(divide="ignore", invalid="ignore"):
                tight = np.abs(u[0]) / np.abs(u[2]) < r
            u[2] = np.where(tight, np.sign(u[2]) * np.abs(u[0]) / r, u[2])

    def _fallback(self, fail: bool) -> bool:
        """Nav2's ``fallback``: on failure reset and retry, up to retry_attempt_limit times in a row."""
        if not fail:
            self._fail_count = 0
            return False
        self.reset()
        self._fail_count += 1
        if self._fail_count > self.p.retry_attempt_limit:
            self._fail_count = 0
            raise NoValidControl("MPPI: optimizer fail to compute path (every trajectory collides)")
        return True

    def _smooth(self) -> None:
        """Nav2's ``savitskyGolayFilter`` over all but the last control, the 4 last commands as history."""
        t = self.p.time_steps
        if t - 1 < 20:
            return
        for a in range(3):
            padded = np.concatenate([self.history[:, a], self.u[a], np.repeat(self.u[a, -1], 4)])
            self.u[a, :-1] = np.correlate(padded, SAVITZKY_GOLAY, mode="valid")[: t - 1]
        k = 1 if self.shift else 0
        self.history[:-1] = self.history[1:].copy()
        self.history[-1] = self.u[:, k]


def _accel_clamp(v: float, last: float, up: float, down: float) -> float:
    """Clamp ``v`` to what an acceleration of ``up`` and a deceleration of ``down`` (<= 0) allow from ``last``."""
    if last > 0:
        return min(max(v, last + down), last + up)
    return min(max(v, last - up), last - down)
