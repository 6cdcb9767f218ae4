"""What every part of a view shares: the RecordingStream, the options, the summary, names and colours.

``ViewContext`` wraps the stream being drawn into. Entity paths are registered in the summary as
they are used (``entity``); an entity is attached to a TF frame once (``set_frame``); times are sent
on the ``sim_time`` timeline as durations from ``offset_ns`` (``time_column``, ``set_time``).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

import numpy as np

from navlog.analysis.view.options import ViewOptions, ViewSummary

TIMELINE = "sim_time"
TIMELINE_REACH_NS = (1 << 63) - 1  # the timeline's durations are signed 64-bit nanoseconds

# role -> RGB: one colour per kind of stream in every view, from the Okabe-Ito palette (told apart by
# readers with any of the common colour-vision deficiencies); amber, orange and red are kept for the
# collision monitor's states, the velocity chain is grey -> orange -> white (plots only).
COLORS = {
    "ground_truth": (0, 158, 115),  # bluish green
    "estimate": (86, 180, 233),  # sky blue: the robot's own odometry
    "estimate2": (0, 114, 178),  # blue: a mapper's or localiser's estimate (/Odometry, a replay's poses)
    "replay": (0, 114, 178),
    "replay_file": (255, 255, 255),  # white, thin: trajectory.tum over the replay's estimate it saves
    "plan": (204, 121, 167),  # reddish purple
    "loop": (204, 121, 167),  # a SLAM's loop closures (a mapping replay has no plan)
    "local_plan": (213, 94, 0),  # vermillion
    "goal": (255, 255, 255),
    "waypoint": (190, 190, 190),
    "scan": (240, 228, 66),  # yellow
    "cloud": (200, 200, 200),  # light grey: 3D LiDAR clouds
    "footprint": (230, 159, 0),  # orange: the robot
}


def entity_name(topic: str) -> str:
    """An entity path segment list for a topic: '/odom/ground_truth' -> 'odom/ground_truth'."""
    parts = [re.sub(r"[^A-Za-z0-9_\-]", "_", p) for p in topic.strip("/").split("/") if p]
    return "/".join(parts) or "root"


def trajectory_role(topic: str) -> str:
    """The colour role of a pose topic: replay output, ground truth, or an estimate."""
    if topic.startswith("replay"):
        return "replay_file" if topic.endswith("trajectory_tum") else "replay"
    if "ground_truth" in topic:
        return "ground_truth"
    return "estimate2" if topic.endswith(("/Odometry", "/amcl_pose", "/pose")) else "estimate"


def _ns(arr: Iterable[int]) -> np.ndarray:
    return np.asarray(list(arr) if not isinstance(arr, np.ndarray) else arr, dtype=np.int64).astype("timedelta64[ns]")


class ViewContext:
    """The stream drawn into, with the bookkeeping shared by every drawer of one view."""

    def __init__(self, rec: Any, options: ViewOptions) -> None:
        import rerun as rr

        self.rr = rr
        self.rec = rec
        self.opt = options
        self.summary = ViewSummary()
        self.offset_ns: int | None = None  # set by the first log read
        self.start_ns = 0  # log time of the first log's first message
        self.frames_used: set[str] = set()
        self._logged_once: set[str] = set()

    def frame(self, frame: str) -> str:
        """A frame name as drawn: leading '/' and the configured prefix stripped."""
        f = frame.lstrip("/")
        p = self.opt.frame_prefix
        if p and f.startswith(p):
            f = f[len(p) :]
        return f

    def entity(self, path: str) -> str:
        """Register an entity path as drawn; returns it."""
        self.summary.entities.add("/" + path.strip("/"))
        return path

    def first_time(self, key: str) -> bool:
        """True the first time ``key`` is asked for (static items are logged once)."""
        if key in self._logged_once:
            return False
        self._logged_once.add(key)
        return True

    def set_frame(self, entity: str, frame: str) -> None:
        """Attach an entity to a named TF frame, once (static)."""
        frame = self.frame(frame)
        if not self.first_time(entity):
            return
        self.frames_used.add(frame)
        self.rec.log(entity, self.rr.CoordinateFrame(frame), static=True)

    def on_timeline(self, t_ns: int) -> bool:
        """Whether log time ``t_ns`` can be drawn: a signed 64-bit count of nanoseconds, as the view keeps its
        times, and as far from ``offset_ns`` as the ``sim_time`` timeline reaches (about 292 years either way).
        An MCAP log time is unsigned and may lie beyond both."""
        return t_ns <= TIMELINE_REACH_NS and -TIMELINE_REACH_NS <= t_ns - (self.offset_ns or 0) <= TIMELINE_REACH_NS

    def time_column(self, t_ns: Iterable[int]):
        """A ``sim_time`` column of log times (ns)."""
        off = self.offset_ns or 0
        return self.rr.TimeColumn(TIMELINE, duration=_ns(np.asarray(list(t_ns), dtype=np.int64) - off))

    def set_time(self, t_ns: int) -> None:
        self.rec.set_time(TIMELINE, duration=np.timedelta64(int(t_ns - (self.offset_ns or 0)), "ns"))

    def send_sensor_points(
        self, topic: str, frame: str, times: list[int], xyz: np.ndarray, lengths: list[int], **style: Any
    ) -> None:
        """Rows of 3D points (``lengths`` points per log time) of a sensor topic under ``sensors/``, in
        its frame; the first batch also logs the entity's static ``style`` (Points3D fields)."""
        rr = self.rr
        ent = self.entity(f"sensors/{entity_name(topic)}")
        self.set_frame(ent, frame)
        self.rec.send_columns(
            ent, indexes=[self.time_column(times)], columns=rr.Points3D.columns(positions=xyz).partition(lengths)
        )
        if self.first_time(f"{ent}#style"):
            self.rec.log(ent, rr.Points3D.from_fields(**style), static=True)
        self.summary.points += len(xyz)
        self.summary.drawn[topic] = ent
