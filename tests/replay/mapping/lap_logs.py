"""Long 2D logs made from a real one: the log played forward, then backward, then forward, ...

A lap is the whole source log (its scans, its odometry on ``/odom`` and ``/tf``); an even lap plays it
forward, an odd one backward: the same instants in reverse order, the robot driving the same path back
(each scan where it was taken, the twist reversed). Lap times continue from the previous lap's last
instant with the source's spacing (forward: the gaps as they were; backward: the gaps in reverse
order); the instant a lap turns at is not repeated, so stamps increase strictly. The odometry
continues from where the previous lap ended by composing the source's increments in the lap's order:
every lap's odometry is the source's, carried by one rigid transform (``LapTime.carry``) that puts
its first instant on the previous lap's last pose. ``/tf_static`` is written once, first.

``write_laps`` writes such a log with navlog's MCAP writer (the source's topics and schemas), and
``lap_times`` maps the source's stamps onto each lap's (for a reference trajectory repeated the
same way). Used by ``tests/replay/mapping/test_lap_logs.py`` and ``benchmarks/bench_slam_long.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import LogError
from navlog.replay import messages
from navlog.replay.geometry import planar_matrix, quat_from_yaw, yaw_from_matrix
from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Envelope

TOPICS = ("/scan", "/odom", "/tf", "/tf_static")


def yaw_of(q: Any) -> float:
    """The yaw of a geometry_msgs/Quaternion."""
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2)))


@dataclass(frozen=True)
class LapTime:
    """How lap ``lap`` places the source's instant ``t`` (ns): ``start + (t - first)`` forward,
    ``start + (last - t)`` backward; ``carry`` (4x4) takes the source's odometry poses to the lap's."""

    lap: int
    start: int  # ns: the lap time of the source's first (forward) or last (backward) instant
    first: int
    last: int
    carry: np.ndarray
    forward_only: bool = False  # every lap forward (a tour repeated), not forward then backward

    @property
    def backward(self) -> bool:
        return self.lap % 2 == 1 and not self.forward_only

    def __call__(self, t: int) -> int:
        return self.start + (self.last - t if self.backward else t - self.first)

    def instants(self, source: list[int]) -> list[int]:
        """The source's instants this lap plays, in its order (the turning instant only once over the laps)."""
        order = source[::-1] if self.backward else source
        return order if self.lap == 0 or self.forward_only else order[1:]


def _odometry_poses(log: Path) -> dict[int, np.ndarray]:
    """The odom -> base pose (4x4) of each ``/tf`` instant of the source."""
    poses: dict[int, np.ndarray] = {}
    with open_log(log) as reader:
        for env in reader.messages(["/tf"]):
            for ts in env.msg.transforms:
                tr, q = ts.transform.translation, ts.transform.rotation
                poses[env.time_ns] = planar_matrix(tr.x, tr.y, yaw_of(q))
    return poses


def lap_times(
    source: list[int], odometry: dict[int, np.ndarray], laps: int, back_to_start: np.ndarray | None = None
) -> list[LapTime]:
    """The ``laps`` laps over the source's sorted instants, each continuing the previous one's time and odometry.

    With ``back_to_start`` (4x4: the motion from where the source ends to where it starts, in the end
    pose's frame) every lap is forward: the next lap's first instant follows the previous lap's last
    after the source's median spacing, its odometry that motion away."""
    if len(source) < 2:
        raise LogError("a lap log needs a source with at least two instants")
    first, last = source[0], source[-1]
    if back_to_start is not None:
        step = int(np.median(np.diff(source)))
        out = [LapTime(0, first, first, last, np.eye(4), True)]
        for lap in range(1, laps):
            prev = out[-1]
            carry = prev.carry @ odometry[last] @ back_to_start @ np.linalg.inv(odometry[first])
            out.append(LapTime(lap, prev(last) + step, first, last, carry, True))
        return out
    out = [LapTime(0, first, first, last, np.eye(4))]
    for lap in range(1, laps):
        prev = out[-1]
        turn = prev.instants(source)[-1]  # the source instant the previous lap ended at: this lap's first
        end = prev(turn)
        carry = prev.carry @ odometry[turn] @ np.linalg.inv(odometry[turn]) if turn in odometry else prev.carry
        out.append(LapTime(lap, end, first, last, carry))
    return out


def _restamp(msg: Any, when: LapTime) -> Any:
    """The message with its header at the lap's time."""
    return replace(msg, header=messages.header(when(messages.to_ns(msg.header.stamp)), msg.header.frame_id))


def _lap_message(env: Envelope, when: LapTime) -> Any:
    msg = env.msg
    if env.topic == "/tf":
        out = []
        for ts in msg.transforms:
            tr, q = ts.transform.translation, ts.transform.rotation
            m = when.carry @ planar_matrix(tr.x, tr.y, yaw_of(q))
            stamp = when(messages.to_ns(ts.header.stamp))
            out.append(
                messages.transform_stamped(
                    stamp,
                    ts.header.frame_id,
                    ts.child_frame_id,
                    (m[0, 3], m[1, 3], tr.z),
                    quat_from_yaw(yaw_from_matrix(m)),
                )
            )
        return messages.tf_message(out)
    if env.topic == "/odom":
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        m = when.carry @ planar_matrix(p.x, p.y, yaw_of(q))
        sign = -1.0 if when.backward else 1.0  # driving the path back: every velocity reversed
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        return messages.odometry(
            when(messages.to_ns(msg.header.stamp)),
            msg.header.frame_id,
            msg.child_frame_id,
            (m[0, 3], m[1, 3], p.z),
            quat_from_yaw(yaw_from_matrix(m)),
            (sign * lin.x, sign * lin.y, sign * lin.z),
            (sign * ang.x, sign * ang.y, sign * ang.z),
            msg.pose.covariance,
            msg.twist.covariance,
        )
    return _restamp(msg, when)  # /scan: the same readings where they were taken


def write_laps(
    source: Path, out: Path, laps: int, back_to_start: np.ndarray | None = None
) -> tuple[Path, list[LapTime]]:
    """Write ``laps`` laps of the ``source`` log (forward, backward, ...; all forward with ``back_to_start``,
    see ``lap_times``) to the MCAP file ``out``; the laps' times."""
    by_instant: dict[int, list[Envelope]] = {}
    statics: list[Envelope] = []
    with open_log(source) as reader:
        missing = [t for t in TOPICS if t not in reader.topics]
        if missing:
            raise LogError(f"{source}: no {', '.join(missing)}; a lap log needs {', '.join(TOPICS)}")
        for env in reader.messages(list(TOPICS)):
            (statics if env.topic == "/tf_static" else by_instant.setdefault(env.time_ns, [])).append(env)
    source_instants = sorted(by_instant)
    times = lap_times(source_instants, _odometry_poses(source), laps, back_to_start)
    with McapLogWriter(out) as writer:
        for env in statics:
            writer.write(Envelope(env.topic, env.typename, source_instants[0], env.msg))
        for when in times:
            for t in when.instants(source_instants):
                for env in by_instant[t]:  # an instant's messages in the source's order
                    writer.write(Envelope(env.topic, env.typename, when(t), _lap_message(env, when)))
    return out, times
