"""Time series under ``plots/``: the velocity chain, speed, odometry drift against ground truth, IMU rates.

The velocity chain (``/cmd_vel_nav`` -> ``/cmd_vel_smoothed`` -> ``/cmd_vel``) is plotted in that
order, other Twist topics after it; vy only when it was ever commanded. Every series records its
value range in ``summary.plot_ranges`` (IMU rates: the 1st to 99th percentile, so that a few spikes
do not flatten the plot), from which the blueprint sets each plot's y axis.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name, trajectory_role
from navlog.analysis.view.trajectories import PoseRows
from navlog.replay import messages

VELOCITY_CHAIN = ("/cmd_vel_nav", "/cmd_vel_smoothed", "/cmd_vel")
# the velocity chain: controller grey, smoother orange, collision monitor's output (what the robot gets) white
CHAIN_COLORS = {"/cmd_vel_nav": (150, 150, 150), "/cmd_vel_smoothed": (230, 159, 0), "/cmd_vel": (255, 255, 255)}
IMU_COLORS = {"wz": (240, 228, 66), "ax": (86, 180, 233)}
# px: each stage of the chain thinner than the one before, so equal values show as nested lines
CHAIN_WIDTHS = {"/cmd_vel_nav": 5.0, "/cmd_vel_smoothed": 3.0, "/cmd_vel": 1.5}


def drift_series(
    t_est: np.ndarray, xyz_est: np.ndarray, t_true: np.ndarray, xyz_true: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position difference (m) of an estimate from the truth, both shifted to start at their first pose.

    Evaluated at the estimate's times inside the truth's time span (truth linearly interpolated).
    Returns (times, distances).
    """
    if len(t_est) == 0 or len(t_true) < 2:
        return np.zeros(0, np.int64), np.zeros(0)
    inside = (t_est >= t_true[0]) & (t_est <= t_true[-1])
    t = t_est[inside]
    if len(t) == 0:
        return np.zeros(0, np.int64), np.zeros(0)
    tt = (t_true - t_true[0]).astype(np.float64)
    te = (t - t_true[0]).astype(np.float64)
    truth = np.stack([np.interp(te, tt, xyz_true[:, k]) for k in range(3)], axis=1)
    est = xyz_est[inside]
    d = (est - est[0]) - (truth - truth[0])
    return t, np.linalg.norm(d, axis=1)


class TimeSeries:
    """Twist and IMU topics: (log time, values...) rows."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.twists: dict[str, list] = defaultdict(list)  # (t, vx, vy, wz)
        self.imu: dict[str, list] = defaultdict(list)  # (t, wz, ax, ay)

    def on_twist(self, topic: str, t: int, msg: Any) -> None:
        self.twists[topic].append((t, *messages.twist_values(msg)))

    def on_imu(self, topic: str, t: int, msg: Any) -> None:
        self.imu[topic].append((t, msg.angular_velocity.z, msg.linear_acceleration.x, msg.linear_acceleration.y))

    def scalars(
        self,
        ent: str,
        t: list[int] | np.ndarray,
        v: np.ndarray,
        name: str,
        color=None,
        width: float | None = None,
        robust: bool = False,
    ) -> None:
        """One named, coloured series of scalars (``width``: line width in px, else Rerun's); its range
        (``robust``: 1st to 99th percentile) goes to ``summary.plot_ranges``."""
        ctx, rr = self.ctx, self.ctx.rr
        ent = ctx.entity(ent)
        finite = np.asarray(v, dtype=np.float64)
        finite = finite[np.isfinite(finite)]
        if len(finite):
            lo, hi = np.percentile(finite, [1, 99]) if robust else (finite.min(), finite.max())
            ctx.summary.plot_ranges["/" + ent.strip("/")] = (float(lo), float(hi))
        ctx.rec.send_columns(
            ent, indexes=[ctx.time_column(t)], columns=rr.Scalars.columns(scalars=np.asarray(v, dtype=np.float64))
        )
        ctx.rec.log(ent, rr.SeriesLines(names=name, colors=[color] if color else None, widths=width), static=True)

    def send(self, odometry: dict[str, PoseRows]) -> None:
        """The twists, then speed and drift of the ``odometry`` topics, then the IMU rates."""
        drawn = self.ctx.summary.drawn
        chain = [t for t in VELOCITY_CHAIN if t in self.twists] + sorted(
            t for t in self.twists if t not in VELOCITY_CHAIN
        )
        for topic in chain:
            arr = np.array(self.twists[topic], dtype=np.float64)
            t = arr[:, 0].astype(np.int64)
            name = entity_name(topic)
            color, width = CHAIN_COLORS.get(topic), CHAIN_WIDTHS.get(topic)
            self.scalars(f"plots/cmd_vel/vx/{name}", t, arr[:, 1], topic, color, width)
            if np.any(arr[:, 2] != 0):
                self.scalars(f"plots/cmd_vel/vy/{name}", t, arr[:, 2], topic, color, width)
            self.scalars(f"plots/cmd_vel/wz/{name}", t, arr[:, 3], topic, color, width)
            drawn[topic] = f"plots/cmd_vel/*/{name}"
        for topic, o in sorted(odometry.items()):
            if o.speed:
                self.scalars(
                    f"plots/speed/{entity_name(topic)}", o.t, np.array(o.speed), topic, COLORS[trajectory_role(topic)]
                )
        truth = next((k for k in sorted(odometry) if "ground_truth" in k), None)
        if truth is not None:
            gt = odometry[truth]
            for topic, o in sorted(odometry.items()):
                if topic == truth or not o.t or "trajectory_tum" in topic:
                    continue
                t, d = drift_series(np.array(o.t), np.array(o.xyz), np.array(gt.t), np.array(gt.xyz))
                if len(t):
                    self.scalars(
                        f"plots/metrics/drift/{entity_name(topic)}",
                        t,
                        d,
                        f"{topic} drift (m)",
                        COLORS[trajectory_role(topic)],
                    )
        for topic, rows in sorted(self.imu.items()):
            arr = np.array(rows, dtype=np.float64)
            t = arr[:, 0].astype(np.int64)
            name = entity_name(topic)
            self.scalars(f"plots/imu/{name}/wz", t, arr[:, 1], f"{topic} yaw rate", IMU_COLORS["wz"], robust=True)
            self.scalars(f"plots/imu/{name}/ax", t, arr[:, 2], f"{topic} accel x", IMU_COLORS["ax"], robust=True)
            drawn[topic] = f"plots/imu/{entity_name(topic)}"
