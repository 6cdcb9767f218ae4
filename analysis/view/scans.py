"""Laser scans: points in the sensor frame, sent to the 3D view in batches as the log is read.

The rows are kept (with their header stamps) for the top-down view, which draws them in the fixed
frame once the TF tree is known.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext
from navlog.replay import messages

_ANGLES: dict[tuple[float, float, int], tuple[np.ndarray, np.ndarray]] = {}


def scan_points(msg: Any) -> np.ndarray:
    """(N, 2) float32 points of a LaserScan in its frame; inf, NaN and out-of-range returns dropped."""
    r = np.asarray(msg.ranges, dtype=np.float32)
    key = (float(msg.angle_min), float(msg.angle_increment), len(r))
    cs = _ANGLES.get(key)
    if cs is None:
        a = key[0] + key[1] * np.arange(len(r), dtype=np.float64)
        cs = (np.cos(a).astype(np.float32), np.sin(a).astype(np.float32))
        if len(_ANGLES) < 64:
            _ANGLES[key] = cs
    ok = np.isfinite(r) & (r >= float(msg.range_min)) & (r <= float(msg.range_max))
    return np.stack([r[ok] * cs[0][ok], r[ok] * cs[1][ok]], axis=1)


@dataclass
class ScanRows:
    """The scans of one topic: log times, header stamps, points; ``pending`` rows not yet sent."""

    frame: str = ""
    t: list[int] = field(default_factory=list)
    stamps: list[int] = field(default_factory=list)
    pts: list[np.ndarray] = field(default_factory=list)
    pending: int = 0


class Scans:
    """LaserScan topics, drawn as 3D points in their sensor frames under ``sensors/``."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, ScanRows] = {}

    def on_scan(self, topic: str, t: int, msg: Any) -> None:
        s = self.topics.setdefault(topic, ScanRows(frame=self.ctx.frame(msg.header.frame_id)))
        s.t.append(t)
        s.stamps.append(messages.to_ns(msg.header.stamp))
        s.pts.append(scan_points(msg))
        s.pending += 1
        if s.pending >= self.ctx.opt.batch_rows:
            self.send(topic, s)

    def send(self, topic: str, s: ScanRows) -> None:
        """Send the rows not yet sent."""
        k = s.pending
        if k == 0:
            return
        rows = s.pts[-k:]
        lengths = [len(p) for p in rows]
        xy = np.concatenate(rows) if rows else np.zeros((0, 2), np.float32)
        xyz = np.zeros((len(xy), 3), dtype=np.float32)
        xyz[:, :2] = xy
        self.ctx.send_sensor_points(topic, s.frame, s.t[-k:], xyz, lengths, radii=0.02, colors=[COLORS["scan"]])
        s.pending = 0

    def flush(self) -> None:
        for topic, s in self.topics.items():
            self.send(topic, s)
