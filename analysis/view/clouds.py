"""Point clouds (sensor_msgs/PointCloud2): x, y, z of every n-th finite point, sent in batches."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.analysis.view.context import ViewContext


@dataclass
class CloudRows:
    """The clouds of one topic not yet sent: log times and points."""

    frame: str = ""
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
        self.ctx.send_sensor_points(topic, c.frame, c.t, xyz, lengths, radii=0.015)
        c.t, c.pts = [], []

    def flush(self) -> None:
        for topic, c in self.topics.items():
            self.send(topic, c)
