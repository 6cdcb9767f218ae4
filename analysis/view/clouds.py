"""Point clouds (sensor_msgs/PointCloud2): x, y, z of every n-th finite point, sent in batches.

A topic is thinned to one cloud per ``cloud_period_s`` (the first cloud of each period is kept, the
others counted as skipped): a 3D LiDAR at 10 Hz is most of a log's bytes, and the viewer shows the
latest cloud at the time cursor, so two clouds a second keep the scene readable at a fifth of the size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext


@dataclass
class CloudRows:
    """The clouds of one topic not yet sent: log times and points."""

    frame: str = ""
    last_kept: int | None = None  # log time of the last cloud kept
    t: list[int] = field(default_factory=list)
    pts: list[np.ndarray] = field(default_factory=list)


class Clouds:
    """PointCloud2 topics, drawn as 3D points in their sensor frames under ``sensors/``."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, CloudRows] = {}

    def on_cloud(self, topic: str, t: int, msg: Any) -> None:
        from navlog.replay.pointcloud import read_points

        c = self.topics.setdefault(topic, CloudRows(frame=self.ctx.frame(msg.header.frame_id)))
        period_ns = int(self.ctx.opt.cloud_period_s * 1e9)
        if c.last_kept is not None and t - c.last_kept < period_ns:
            self.ctx.summary.thinned[f"{topic}: one cloud per {self.ctx.opt.cloud_period_s:g} s"] += 1
            return
        c.last_kept = t
        arr = read_points(msg, ("x", "y", "z"))
        pts = np.empty((len(arr), 3), dtype=np.float32)
        pts[:, 0], pts[:, 1], pts[:, 2] = arr["x"], arr["y"], arr["z"]
        stride = self.ctx.opt.cloud_stride
        if stride > 1:
            pts = pts[::stride]
        pts = pts[np.isfinite(pts).all(axis=1)]
        c.t.append(t)
        c.pts.append(pts)
        if len(c.t) >= self.ctx.opt.batch_rows:
            self.send(topic, c)

    def send(self, topic: str, c: CloudRows) -> None:
        """Send the rows collected so far and forget them."""
        if not c.t:
            return
        lengths = [len(p) for p in c.pts]
        xyz = np.concatenate(c.pts) if c.pts else np.zeros((0, 3), np.float32)
        self.ctx.send_sensor_points(
            topic, c.frame, c.t, xyz, lengths, radii=self.ctx.rr.Radius.ui_points(1.5), colors=[COLORS["cloud"]]
        )
        c.t, c.pts = [], []

    def flush(self) -> None:
        for topic, c in self.topics.items():
            self.send(topic, c)
