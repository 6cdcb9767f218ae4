"""Nav2's velocity smoother (``nav2_velocity_smoother``): its parameters, read and checked; not run yet.

The smoother limits the controller's commands (/cmd_vel_nav -> /cmd_vel_smoothed) to the velocity,
acceleration and deceleration bounds per axis; its implementation will sit in this module.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from navlog.replay.nav2.schema import ERROR, SectionReader, param


@dataclass(frozen=True)
class VelocitySmootherParams:
    """``velocity_smoother`` node parameters (velocity vectors: vx, vy, wz or 6 axes)."""

    smoothing_frequency: float = param(20.0, gt=0.0)
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
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "use_realtime_priority",
        "enable_stamped_cmd_vel",
        "stamp_smoothed_velocity_with_smoothing_time",
        "use_sim_time",
    )


def read_velocity_smoother(r: SectionReader, params: dict, path: tuple) -> VelocitySmootherParams:
    """The node's parameters, with the vector lengths and signs Nav2 requires."""
    vs = r.read(VelocitySmootherParams, params, path)
    keys = ("max_velocity", "min_velocity", "max_accel", "max_decel", "deadband_velocity")
    sizes = {k: len(getattr(vs, k)) for k in keys}
    for k, n in sizes.items():
        if n not in (3, 6):
            r.add(ERROR, path + (k,), f"has {n} entries: expected 3 (vx, vy, wz) or 6")
    if len(set(sizes.values())) > 1:
        r.add(ERROR, path, f"velocity vectors differ in length: {sizes}")
    axes = ("vx", "vy", "wz", "vz", "wx", "wy")
    for k, sign, word in (
        ("max_decel", -1, "<= 0"),
        ("max_accel", 1, ">= 0"),
        ("min_velocity", -1, "<= 0"),
        ("max_velocity", 1, ">= 0"),
    ):
        for i, v in enumerate(getattr(vs, k)):
            if v * sign < 0:
                r.add(
                    ERROR,
                    path + (k,),
                    f"{k}[{i}] ({axes[i] if i < 6 else i}) = {v}: must be {word}; Nav2 rejects the configuration",
                )
    return vs
