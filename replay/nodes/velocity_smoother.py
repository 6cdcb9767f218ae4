"""The velocity smoother node: /cmd_vel_nav -> /cmd_vel_smoothed, Nav2's ``velocity_smoother`` on the executor.

Subscribes to the controller's commands (Twist or TwistStamped, whichever the topic carries) and, in
``CLOSED_LOOP``, to odometry (nav_msgs/Odometry on ``odom_topic``, by default ``/`` + the parameter
``odom_topic``). A timer on sim time at ``smoothing_frequency`` runs one step of
``navlog.replay.nav2.velocity_smoother.VelocitySmoother`` and publishes its command: a Twist, or a
TwistStamped (the command's stamp and frame) when ``enable_stamped_cmd_vel`` is true. The timer
period is Nav2's, whole milliseconds (``int(1000 / smoothing_frequency)``: 50 ms at 20 Hz); the
acceleration step stays the nominal 1 / smoothing_frequency.

A command or odometry twist holding NaN or infinity is skipped and counted (``counts()``), never
propagated. Nav2 runs this timer on the wall clock; here it runs on sim time, so a replay gives the
same output at any speed.
"""

from __future__ import annotations

import math
from typing import Any

from navlog.replay import messages
from navlog.replay.nav2.velocity_smoother import SmoothedCommand, VelocitySmoother, VelocitySmootherParams
from navlog.replay.runtime.executor import Node


def _twist(msg: Any) -> Any:
    return msg.twist if hasattr(msg, "twist") else msg


def twist_axes(twist: Any, n_axes: int) -> tuple[float, ...]:
    """The smoother's axes of a Twist: (vx, vy, wz), or (vx, vy, vz, wx, wy, wz) for 6 axes."""
    if n_axes == 3:
        return messages.twist_values(twist)
    lin, ang = twist.linear, twist.angular
    return tuple(float(v) for v in (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))


def _finite(twist: Any) -> bool:
    """All six components finite (Nav2's ``validateTwist``)."""
    lin, ang = twist.linear, twist.angular
    return all(map(math.isfinite, (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)))


def twist_msg(values: tuple[float, ...]) -> Any:
    """A geometry_msgs/Twist from the smoother's axes (3 or 6)."""
    if len(values) == 3:
        return messages.twist(*values)
    cls = messages.msg_class(messages.TWIST)
    return cls(messages.vector3(*values[:3]), messages.vector3(*values[3:]))


class VelocitySmootherNode(Node):
    """Nav2's velocity smoother on the executor (see the module docstring)."""

    name = "velocity_smoother"

    def __init__(
        self,
        params: VelocitySmootherParams,
        *,
        input_topic: str = "/cmd_vel_nav",
        output_topic: str = "/cmd_vel_smoothed",
        odom_topic: str | None = None,
    ) -> None:
        super().__init__()
        self.params = params
        self.smoother = VelocitySmoother(params)
        self.input_topic = input_topic
        self.output_topic = output_topic
        topic = params.odom_topic if odom_topic is None else odom_topic
        self.odom_topic = topic if topic.startswith("/") else "/" + topic
        self.published = 0

    @property
    def period_ns(self) -> int:
        """The timer period: Nav2's whole milliseconds of 1000 / smoothing_frequency (at least 1 ns)."""
        ms = int(1000.0 / self.params.smoothing_frequency)
        return ms * 1_000_000 if ms > 0 else max(1, int(1e9 / self.params.smoothing_frequency))

    @property
    def output_type(self) -> str:
        return messages.TWIST_STAMPED if self.params.enable_stamped_cmd_vel else messages.TWIST

    def input_topics(self) -> list[str]:
        return [self.input_topic] + ([] if self.smoother.open_loop else [self.odom_topic])

    def setup(self) -> None:
        self.subscribe(self.input_topic, self._on_command, (messages.TWIST, messages.TWIST_STAMPED))
        if not self.smoother.open_loop:
            self.subscribe(self.odom_topic, self._on_odom, (messages.ODOMETRY,))
        self.create_timer(self.period_ns, self._on_timer)

    def _on_command(self, msg: Any, t_ns: int) -> None:
        twist = _twist(msg)
        if not _finite(twist):
            self.skipped[f"{self.input_topic}: NaN or infinite commands (skipped)"] += 1
            return
        header = getattr(msg, "header", None)
        stamp = messages.to_ns(header.stamp) if header is not None else 0
        frame = header.frame_id if header is not None else ""
        self.smoother.set_command(twist_axes(twist, self.smoother.n_axes), t_ns, stamp, frame)

    def _on_odom(self, msg: Any, t_ns: int) -> None:
        twist = msg.twist.twist
        if not _finite(twist):
            self.skipped[f"{self.odom_topic}: NaN or infinite odometry twists (skipped)"] += 1
            return
        self.smoother.add_odometry(messages.to_ns(msg.header.stamp), twist_axes(twist, self.smoother.n_axes))

    def _on_timer(self, t_ns: int) -> None:
        out = self.smoother.tick(t_ns)
        if out is not None:
            self.publish(self.output_topic, self.output_type, self.command_msg(out))
            self.published += 1

    def command_msg(self, out: SmoothedCommand) -> Any:
        """The message published for one smoothed command (Twist or TwistStamped)."""
        twist = twist_msg(out.values)
        if not self.params.enable_stamped_cmd_vel:
            return twist
        return messages.msg_class(messages.TWIST_STAMPED)(messages.header(out.stamp_ns, out.frame_id), twist)
