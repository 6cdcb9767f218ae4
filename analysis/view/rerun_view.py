"""A Rerun recording of a navigation log, with a default blueprint.

``build_view(reader, rec)`` reads a log once and draws what a navigation engineer looks at:

- a 3D view in the fixed frame (``map`` when the TF tree has it): LiDAR clouds and laser scans in
  their sensor frames, the TF tree, true and estimated trajectories, plans, occupancy grids,
  goals and waypoints as labelled arrows, and the replay outputs (PCD map, trajectory) when given;
- a top-down 2D view: the occupancy grid (or costmap), scan points and the robot footprint, all
  drawn in the pixel space of one fixed canvas in the fixed frame;
- time series: the velocity chain (``/cmd_vel_nav`` -> ``/cmd_vel_smoothed`` -> ``/cmd_vel``),
  speed, odometry drift against ground truth, IMU rates; events as a text log.

The timeline ``sim_time`` is a duration: the log time itself for simulator logs (sim time in
nanoseconds), the time since the first message for bags recorded with wall-clock receive times.
Everything high-rate goes through ``send_columns``; per-row ``log`` is used only for grids,
goals and static items. Topics of other types are counted as stored but not drawn.

``save_view`` writes an ``.rrd`` under a temporary name and renames it when complete.
"""

from __future__ import annotations

import logging
import math
import os
import re
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import LogError, NavlogError
from navlog.replay import messages
from navlog.replay.io.logreader import LogReader, open_log
from navlog.replay.runtime.tf import TFBuffer, TransformError

log = logging.getLogger("navlog")

TIMELINE = "sim_time"
# A log whose first message is later than this (about three years after 1970) was stamped with
# wall-clock receive times; its timeline then starts at zero.
WALL_CLOCK_NS = 100_000_000_000_000_000
VELOCITY_CHAIN = ("/cmd_vel_nav", "/cmd_vel_smoothed", "/cmd_vel")
# Go2 body outline (0.70 x 0.31 m) around base_footprint.
GO2_FOOTPRINT = ((0.35, 0.155), (0.35, -0.155), (-0.35, -0.155), (-0.35, 0.155))
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POSE_COV_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
STRING = "std_msgs/msg/String"
ROSOUT = "rcl_interfaces/msg/Log"
ROSOUT_LEVELS = {10: "DEBUG", 20: "INFO", 30: "WARN", 40: "ERROR", 50: "CRITICAL"}

# role -> RGB
COLORS = {
    "ground_truth": (40, 200, 80),
    "estimate": (255, 140, 20),
    "estimate2": (40, 120, 255),
    "replay": (200, 60, 220),
    "plan": (230, 30, 30),
    "goal": (255, 215, 0),
    "waypoint": (0, 200, 220),
    "scan": (255, 60, 60),
    "footprint": (30, 90, 255),
}
CHAIN_COLORS = {"/cmd_vel_nav": (120, 120, 255), "/cmd_vel_smoothed": (255, 165, 0), "/cmd_vel": (220, 30, 30)}


@dataclass(frozen=True)
class ViewOptions:
    """What to draw and how; validated once by ``validate``."""

    fixed_frame: str = ""  # "" : "map" if the TF tree has it, else the root of the largest TF tree
    frame_prefix: str = ""  # stripped from every frame name (e.g. "simple_robot/")
    footprint: tuple[tuple[float, float], ...] | None = None  # None: the log's robot radius, else the Go2 outline
    grid_period_s: float = 1.0  # grids faster than this are thinned to one per period
    cloud_stride: int = 1  # keep every n-th point of each cloud
    batch_rows: int = 64  # messages per send_columns batch for clouds and scans
    max_canvas_px: int = 4000  # the top-down canvas is at most this many pixels on a side

    def validate(self) -> ViewOptions:
        if self.footprint is not None and len(self.footprint) < 3:
            raise NavlogError(f"footprint: needs at least 3 points, got {len(self.footprint)}")
        if self.grid_period_s < 0:
            raise NavlogError(f"grid_period_s: must be >= 0, got {self.grid_period_s}")
        if self.cloud_stride < 1 or self.batch_rows < 1 or self.max_canvas_px < 16:
            raise NavlogError("cloud_stride and batch_rows must be >= 1, max_canvas_px >= 16")
        return self


@dataclass
class ViewSummary:
    """What the recording holds: entities, the topics drawn and not drawn, what was skipped."""

    fixed_frame: str = ""
    time_offset_ns: int = 0
    wall_clock: bool = False
    entities: set[str] = field(default_factory=set)
    drawn: dict[str, str] = field(default_factory=dict)  # topic -> entity
    not_drawn: dict[str, str] = field(default_factory=dict)  # topic -> type
    unknown_types: dict[str, str] = field(default_factory=dict)
    skipped: Counter = field(default_factory=Counter)
    warnings: list[str] = field(default_factory=list)
    messages: int = 0
    points: int = 0
    has_top: bool = False
    grid_source: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {
            "fixed_frame": self.fixed_frame,
            "time_offset_ns": self.time_offset_ns,
            "wall_clock": self.wall_clock,
            "messages": self.messages,
            "points": self.points,
            "entities": sorted(self.entities),
            "drawn": dict(sorted(self.drawn.items())),
            "not_drawn": dict(sorted(self.not_drawn.items())),
            "unknown_types": dict(sorted(self.unknown_types.items())),
            "skipped": dict(sorted(self.skipped.items())),
            "warnings": list(self.warnings),
            "grid_source": self.grid_source,
        }


# ---------------------------------------------------------------- pure helpers


def entity_name(topic: str) -> str:
    """An entity path segment list for a topic: '/odom/ground_truth' -> 'odom/ground_truth'."""
    parts = [re.sub(r"[^A-Za-z0-9_\-]", "_", p) for p in topic.strip("/").split("/") if p]
    return "/".join(parts) or "root"


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


def grid_array(msg: Any) -> np.ndarray:
    """OccupancyGrid data as an (height, width) int8 array, row 0 at the grid origin."""
    info = msg.info
    data = np.asarray(msg.data, dtype=np.int8)
    return data[: int(info.width) * int(info.height)].reshape(int(info.height), int(info.width))


def grid_gray(cells: np.ndarray) -> np.ndarray:
    """map_server colours: occupied black, free white, unknown grey, costs in between."""
    v = cells.astype(np.int16)
    out = np.full(v.shape, 205, dtype=np.uint8)
    known = v >= 0
    out[known] = (254 - np.clip(v[known], 0, 100) * 254 // 100).astype(np.uint8)
    return out


@dataclass(frozen=True)
class Canvas:
    """A top-down raster in the fixed frame: pixel (u, v) with u east, v south, 1 px = res metres."""

    x0: float
    y1: float
    res: float
    width: int
    height: int

    @staticmethod
    def around(xmin: float, ymin: float, xmax: float, ymax: float, res: float, max_px: int) -> Canvas:
        res = max(res, max(xmax - xmin, ymax - ymin) / max_px, 1e-3)
        w = int(math.ceil((xmax - xmin) / res)) or 1
        h = int(math.ceil((ymax - ymin) / res)) or 1
        return Canvas(xmin, ymin + h * res, res, w, h)

    def to_px(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return np.stack([(xy[:, 0] - self.x0) / self.res, (self.y1 - xy[:, 1]) / self.res], axis=1).astype(np.float32)

    def paste(self, gray_rows_up: np.ndarray, ox: float, oy: float, res: float) -> np.ndarray:
        """An (height, width) image of the canvas with a grid (row 0 at y=oy) drawn into it."""
        img = np.full((self.height, self.width), 205, dtype=np.uint8)
        h, w = gray_rows_up.shape
        if h == 0 or w == 0:
            return img
        if abs(res - self.res) > 1e-9:  # nearest-neighbour resample onto the canvas grid
            cx = self.x0 + (np.arange(self.width) + 0.5) * self.res
            cy = self.y1 - (np.arange(self.height) + 0.5) * self.res
            ci = np.floor((cx - ox) / res).astype(int)
            ri = np.floor((cy - oy) / res).astype(int)
            okc, okr = (ci >= 0) & (ci < w), (ri >= 0) & (ri < h)
            sub = gray_rows_up[np.ix_(ri[okr], ci[okc])]
            img[np.ix_(np.nonzero(okr)[0], np.nonzero(okc)[0])] = sub
            return img
        c0 = int(round((ox - self.x0) / self.res))
        r0 = int(round((self.y1 - (oy + h * res)) / self.res))  # canvas row of the grid's top edge
        flipped = gray_rows_up[::-1]
        rs, cs = max(0, r0), max(0, c0)
        re_, ce = min(self.height, r0 + h), min(self.width, c0 + w)
        if rs < re_ and cs < ce:
            img[rs:re_, cs:ce] = flipped[rs - r0 : re_ - r0, cs - c0 : ce - c0]
        return img


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


def yaw_vectors(q_xyzw: np.ndarray, length: float) -> np.ndarray:
    """(N, 3) arrows along each orientation's x axis."""
    q = np.asarray(q_xyzw, dtype=np.float64).reshape(-1, 4)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    fx = 1 - 2 * (y * y + z * z)
    fy = 2 * (x * y + w * z)
    fz = 2 * (x * z - w * y)
    return np.stack([fx, fy, fz], axis=1) * length


def robot_footprint(metadata: dict[str, dict[str, str]]) -> tuple[tuple[float, float], ...]:
    """A 16-gon of the recorded robot's radius (config/robots/NAME.yaml), else the Go2 outline."""
    from navlog.replay.config import load_yaml, named_config

    name = metadata.get("navlog", {}).get("robot", "")
    try:
        radius = float((load_yaml(named_config("robots", name)) or {}).get("radius", 0.0)) if name else 0.0
    except (NavlogError, TypeError, ValueError, AttributeError):
        radius = 0.0
    if radius <= 0.0:
        return GO2_FOOTPRINT
    a = 2 * math.pi * np.arange(16) / 16
    return tuple((round(radius * math.cos(v), 9), round(radius * math.sin(v), 9)) for v in a)


def _ns(arr: Iterable[int]) -> np.ndarray:
    return np.asarray(list(arr) if not isinstance(arr, np.ndarray) else arr, dtype=np.int64).astype("timedelta64[ns]")


# ---------------------------------------------------------------- collection


@dataclass
class _Odom:
    frame: str = ""
    child: str = ""
    t: list[int] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    q: list[tuple[float, float, float, float]] = field(default_factory=list)
    speed: list[float] = field(default_factory=list)


@dataclass
class _Scans:
    frame: str = ""
    t: list[int] = field(default_factory=list)
    stamps: list[int] = field(default_factory=list)
    pts: list[np.ndarray] = field(default_factory=list)
    pending: int = 0  # rows not yet sent for the 3D view


@dataclass
class _Clouds:
    frame: str = ""
    t: list[int] = field(default_factory=list)
    pts: list[np.ndarray] = field(default_factory=list)


class ViewBuilder:
    """Streams one log into a RecordingStream; call ``add_log`` (and ``add_replay_dir``), then ``finish``."""

    def __init__(self, rec: Any, options: ViewOptions | None = None) -> None:
        import rerun as rr

        self.rr = rr
        self.rec = rec
        self.opt = (options or ViewOptions()).validate()
        self.summary = ViewSummary()
        self.tf = TFBuffer(cache_ns=1 << 62, frame_prefix=self.opt.frame_prefix)
        self.offset_ns: int | None = None
        # per-prefix collections (prefix "" for the log, "replay" for the replay output)
        self._tf_edges: dict[tuple[str, str], dict] = {}
        self._static_logged: set[str] = set()
        self._frames_used: set[str] = set()
        self._scans: dict[str, _Scans] = {}
        self._clouds: dict[str, _Clouds] = {}
        self._odom: dict[str, _Odom] = {}
        self._paths: dict[str, list] = defaultdict(list)
        self._twists: dict[str, list] = defaultdict(list)
        self._grids: dict[str, list] = defaultdict(list)
        self._grid_pending: dict[str, tuple] = {}
        self._goals: dict[str, list] = defaultdict(list)
        self._waypoints: dict[str, list] = defaultdict(list)
        self._events: list[tuple[int, str, str]] = []
        self._imu: dict[str, list] = defaultdict(list)
        self._texts: dict[str, list[tuple[int, str, str]]] = defaultdict(list)
        self._static_grid: tuple[str, np.ndarray, float, float, float] | None = None
        self.footprint: tuple[tuple[float, float], ...] = self.opt.footprint or GO2_FOOTPRINT

    # -------------------------------------------------------------- helpers

    def _frame(self, frame: str) -> str:
        f = frame.lstrip("/")
        p = self.opt.frame_prefix
        if p and f.startswith(p):
            f = f[len(p) :]
        return f

    def _entity(self, path: str) -> str:
        self.summary.entities.add("/" + path.strip("/"))
        return path

    def _set_frame(self, entity: str, frame: str) -> None:
        """Attach an entity to a named TF frame, once (static)."""
        frame = self._frame(frame)
        if entity in self._static_logged:
            return
        self._static_logged.add(entity)
        self._frames_used.add(frame)
        self.rec.log(entity, self.rr.CoordinateFrame(frame), static=True)

    def _tcol(self, t_ns: Iterable[int]):
        off = self.offset_ns or 0
        return self.rr.TimeColumn(TIMELINE, duration=_ns(np.asarray(list(t_ns), dtype=np.int64) - off))

    def _set_time(self, t_ns: int) -> None:
        self.rec.set_time(TIMELINE, duration=np.timedelta64(int(t_ns - (self.offset_ns or 0)), "ns"))

    # -------------------------------------------------------------- input

    def add_log(self, reader: LogReader, prefix: str = "") -> None:
        """Read every message of a log once and collect (bulk sensors are sent in batches as read)."""
        if self.offset_ns is None:
            self.footprint = self.opt.footprint or robot_footprint(reader.metadata)
            wall = reader.start_ns >= WALL_CLOCK_NS
            self.offset_ns = reader.start_ns if wall else 0
            self.summary.wall_clock = wall
            self.summary.time_offset_ns = self.offset_ns
            if wall:
                self.summary.warnings.append(
                    f"{reader.path.name}: receive times are wall-clock; sim_time counts from the first message"
                )
        for name, typename in sorted(reader.unknown_types.items()):
            self.summary.unknown_types[(prefix + name) if prefix else name] = typename
        if reader.unknown_types:
            log.warning(
                "%s: skipping topics of unknown types: %s",
                reader.path,
                ", ".join(f"{t} ({ty})" for t, ty in sorted(reader.unknown_types.items())),
            )
        handlers = {
            messages.LASER_SCAN: self._on_scan,
            messages.POINT_CLOUD2: self._on_cloud,
            messages.TF_MESSAGE: self._on_tf,
            messages.ODOMETRY: self._on_odom,
            messages.PATH: self._on_path,
            messages.TWIST: self._on_twist,
            messages.TWIST_STAMPED: self._on_twist,
            messages.OCCUPANCY_GRID: self._on_grid,
            messages.POSE_STAMPED: self._on_goal,
            POSE_COV_STAMPED: self._on_goal,
            POSE_ARRAY: self._on_waypoints,
            messages.EVENT_TYPE: self._on_event,
            messages.IMU: self._on_imu,
            STRING: self._on_text,
            ROSOUT: self._on_text,
        }
        wanted = []
        for t in sorted(reader.topics.values(), key=lambda t: t.name):
            if not t.known:
                continue
            if t.typename in handlers:
                wanted.append(t.name)
            elif t.typename != messages.CLOCK:
                self.summary.not_drawn[(prefix + t.name) if prefix else t.name] = t.typename
        from navlog.replay.runtime.progress import Progress

        prog = Progress(reader.duration_ns / 1e9, f"view {reader.path.name}", enabled=log.isEnabledFor(logging.WARNING))
        n = 0
        for env in reader.messages(wanted):
            key = f"{prefix}{env.topic}" if prefix else env.topic
            try:
                handlers[env.typename](key, env.time_ns, env.msg, prefix)
            except (AttributeError, ValueError, KeyError, IndexError, TypeError) as exc:
                self.summary.skipped[f"unreadable {env.typename} on {key} ({type(exc).__name__})"] += 1
            n += 1
            if n % 2000 == 0:
                prog.update((env.time_ns - reader.start_ns) / 1e9)
        prog.update(reader.duration_ns / 1e9)
        prog.close()
        self.summary.messages += n
        for reason, count in reader.report.skipped.items():
            self.summary.skipped[reason] += count
        self._flush_bulk(final=True)

    # each handler: (key topic, log time, message, prefix)

    def _on_scan(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        s = self._scans.setdefault(topic, _Scans(frame=self._frame(msg.header.frame_id)))
        s.t.append(t)
        s.stamps.append(messages.to_ns(msg.header.stamp))
        s.pts.append(scan_points(msg))
        s.pending += 1
        if s.pending >= self.opt.batch_rows:
            self._send_scans(topic, s)

    def _on_cloud(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        from navlog.replay.pointcloud import read_points

        c = self._clouds.setdefault(topic, _Clouds(frame=self._frame(msg.header.frame_id)))
        arr = read_points(msg, ("x", "y", "z"))
        pts = np.empty((len(arr), 3), dtype=np.float32)
        pts[:, 0], pts[:, 1], pts[:, 2] = arr["x"], arr["y"], arr["z"]
        if self.opt.cloud_stride > 1:
            pts = pts[:: self.opt.cloud_stride]
        pts = pts[np.isfinite(pts).all(axis=1)]
        c.t.append(t)
        c.pts.append(pts)
        if len(c.t) >= self.opt.batch_rows:
            self._send_clouds(topic, c)

    def _on_tf(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        static = topic.endswith("/tf_static")
        self.tf.add_message(msg, static=static)
        for ts in msg.transforms:
            parent, child = self._frame(ts.header.frame_id), self._frame(ts.child_frame_id)
            e = self._tf_edges.setdefault((parent, child), {"static": static, "t": [], "xyz": [], "q": []})
            tr, r = ts.transform.translation, ts.transform.rotation
            if static:
                e["static"] = True
                e["t"], e["xyz"], e["q"] = [t], [(tr.x, tr.y, tr.z)], [(r.x, r.y, r.z, r.w)]
            else:
                e["t"].append(t)
                e["xyz"].append((tr.x, tr.y, tr.z))
                e["q"].append((r.x, r.y, r.z, r.w))
        self.summary.drawn[topic] = "tf"

    def _on_odom(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        o = self._odom.setdefault(
            topic, _Odom(frame=self._frame(msg.header.frame_id), child=self._frame(msg.child_frame_id))
        )
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        lin = msg.twist.twist.linear
        o.t.append(t)
        o.xyz.append((p.x, p.y, p.z))
        o.q.append((q.x, q.y, q.z, q.w))
        o.speed.append(math.hypot(lin.x, lin.y))

    def _on_path(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        xyz = np.array(
            [(ps.pose.position.x, ps.pose.position.y, ps.pose.position.z) for ps in msg.poses], dtype=np.float32
        ).reshape(-1, 3)
        if "waypoint" in topic.lower():
            q = np.array(
                [
                    (ps.pose.orientation.x, ps.pose.orientation.y, ps.pose.orientation.z, ps.pose.orientation.w)
                    for ps in msg.poses
                ]
            ).reshape(-1, 4)
            self._waypoints[topic].append((t, self._frame(msg.header.frame_id), xyz, q))
        self._paths[topic].append((t, self._frame(msg.header.frame_id), xyz))

    def _on_twist(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        self._twists[topic].append((t, *messages.twist_values(msg)))

    def _on_grid(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        info = msg.info
        o = info.origin
        entry = (
            t,
            self._frame(msg.header.frame_id),
            grid_array(msg).copy(),
            float(info.resolution),
            (o.position.x, o.position.y, o.position.z),
            (o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w),
        )
        grids = self._grids[topic]
        period = self.opt.grid_period_s * 1e9
        if grids and t - grids[-1][0] < period:
            if topic in self._grid_pending:
                self.summary.skipped[f"grid thinned to one per {self.opt.grid_period_s:g} s on {topic}"] += 1
            self._grid_pending[topic] = entry  # the latest of a fast run is kept for the end
            return
        if self._grid_pending.pop(topic, None) is not None:
            self.summary.skipped[f"grid thinned to one per {self.opt.grid_period_s:g} s on {topic}"] += 1
        grids.append(entry)

    def _on_goal(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        p, q = pose.position, pose.orientation
        self._goals[topic].append((t, self._frame(msg.header.frame_id), (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))

    def _on_waypoints(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        xyz = np.array([(p.position.x, p.position.y, p.position.z) for p in msg.poses], dtype=np.float32).reshape(-1, 3)
        q = np.array([(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w) for p in msg.poses]).reshape(
            -1, 4
        )
        self._waypoints[topic].append((t, self._frame(msg.header.frame_id), xyz, q))

    def _on_event(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        text = f"{msg.kind} [{msg.source}]"
        if msg.detail:
            text += f": {msg.detail}"
        if msg.value:
            text += f" ({msg.value:g})"
        bad = any(w in msg.kind.lower() for w in ("fail", "abort", "collision", "stop", "error"))
        self._events.append((t, text, "WARN" if bad else "INFO"))
        self.summary.drawn[topic] = self._entity("events")

    def _on_text(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        if hasattr(msg, "msg"):  # rcl_interfaces/Log (/rosout)
            level = ROSOUT_LEVELS.get(int(msg.level), "INFO")
            self._texts[topic].append((t, f"[{msg.name}] {msg.msg}", level))
        else:
            self._texts[topic].append((t, str(msg.data), "INFO"))

    def _on_imu(self, topic: str, t: int, msg: Any, prefix: str) -> None:
        self._imu[topic].append((t, msg.angular_velocity.z, msg.linear_acceleration.x, msg.linear_acceleration.y))

    # -------------------------------------------------------------- bulk senders

    def _send_scans(self, topic: str, s: _Scans) -> None:
        k = s.pending
        if k == 0:
            return
        ent = self._entity(f"sensors/{entity_name(topic)}")
        self._set_frame(ent, s.frame)
        rows = s.pts[-k:]
        lengths = [len(p) for p in rows]
        xy = np.concatenate(rows) if rows else np.zeros((0, 2), np.float32)
        xyz = np.zeros((len(xy), 3), dtype=np.float32)
        xyz[:, :2] = xy
        rr = self.rr
        self.rec.send_columns(
            ent, indexes=[self._tcol(s.t[-k:])], columns=rr.Points3D.columns(positions=xyz).partition(lengths)
        )
        if f"{ent}#style" not in self._static_logged:
            self._static_logged.add(f"{ent}#style")
            self.rec.log(ent, rr.Points3D.from_fields(radii=0.02, colors=[COLORS["scan"]]), static=True)
        self.summary.points += len(xyz)
        self.summary.drawn[topic] = ent
        s.pending = 0

    def _send_clouds(self, topic: str, c: _Clouds) -> None:
        if not c.t:
            return
        ent = self._entity(f"sensors/{entity_name(topic)}")
        self._set_frame(ent, c.frame)
        lengths = [len(p) for p in c.pts]
        xyz = np.concatenate(c.pts) if c.pts else np.zeros((0, 3), np.float32)
        rr = self.rr
        self.rec.send_columns(
            ent, indexes=[self._tcol(c.t)], columns=rr.Points3D.columns(positions=xyz).partition(lengths)
        )
        if f"{ent}#style" not in self._static_logged:
            self._static_logged.add(f"{ent}#style")
            self.rec.log(ent, rr.Points3D.from_fields(radii=0.015), static=True)
        self.summary.points += len(xyz)
        self.summary.drawn[topic] = ent
        c.t, c.pts = [], []

    def _flush_bulk(self, final: bool = False) -> None:
        for topic, s in self._scans.items():
            self._send_scans(topic, s)
        for topic, c in self._clouds.items():
            self._send_clouds(topic, c)

    # -------------------------------------------------------------- replay outputs

    def add_replay_dir(self, out: Path) -> None:
        """Draw a replay output folder: replay.mcap topics, map.yaml/pgm, map.pcd, trajectory.tum."""
        out = Path(out)
        if not out.is_dir():
            raise NavlogError(f"{out}: replay output folder does not exist")
        found = False
        mcap = out / "replay.mcap"
        if mcap.is_file():
            with open_log(mcap) as r:
                self.add_log(r, prefix="replay")
            found = True
        if (out / "map.yaml").is_file():
            found |= self._add_map_yaml(out / "map.yaml")
        if (out / "map.pcd").is_file():
            self._add_pcd(out / "map.pcd")
            found = True
        if (out / "trajectory.tum").is_file():
            self._add_tum(out / "trajectory.tum")
            found = True
        if not found:
            raise NavlogError(
                f"{out}: no replay outputs found (expected replay.mcap, map.yaml, map.pcd or trajectory.tum)"
            )

    def _add_map_yaml(self, path: Path) -> bool:
        from navlog.replay.io.map_server import load_map

        occ = load_map(path)
        ox, oy, yaw = occ.origin
        self._static_grid = ("replay/map", occ.data, occ.resolution, ox, oy)
        ent = self._entity("replay/map")
        self._set_frame(ent, occ.frame_id or "map")
        self.rec.log(
            ent, self._gridmap(occ.data, occ.resolution, (ox, oy, 0.0), messages.quat_from_yaw(yaw)), static=True
        )
        self.summary.drawn[str(path)] = ent
        return True

    def _add_pcd(self, path: Path) -> None:
        import open3d as o3d

        pcd = o3d.io.read_point_cloud(str(path))
        pts = np.asarray(pcd.points, dtype=np.float32)
        if len(pts) == 0:
            self.summary.warnings.append(f"{path}: empty point cloud")
        ent = self._entity("replay/map_pcd")
        self._set_frame(ent, self.opt.fixed_frame or "map")
        z = pts[:, 2] if len(pts) else np.zeros(0)
        self.rec.log(ent, self.rr.Points3D(pts, radii=0.02, colors=_height_colors(z)), static=True)
        self.summary.points += len(pts)
        self.summary.drawn[str(path)] = ent

    def _add_tum(self, path: Path) -> None:
        from navlog.analysis.tum import read_tum

        traj = read_tum(path)
        o = _Odom(frame=self.opt.fixed_frame or "map", child="")
        o.t = [int(v) for v in traj.times_ns]
        o.xyz = [tuple(r) for r in traj.positions]
        o.q = [tuple(r) for r in traj.quaternions]
        self._odom["replay/trajectory_tum"] = o

    # -------------------------------------------------------------- finish

    def finish(self) -> ViewSummary:
        """Send everything collected, choose the fixed frame and send the blueprint."""
        self._flush_bulk(final=True)
        self._choose_fixed_frame()
        self._send_tf()
        self._send_trajectories()
        self._send_paths()
        self._send_goals()
        self._send_grids()
        self._send_top()
        self._send_plots()
        self._send_events()
        self._link_orphan_frames()
        self.rec.send_blueprint(make_blueprint(self.summary), make_active=True, make_default=True)
        return self.summary

    def _choose_fixed_frame(self) -> None:
        if self.opt.fixed_frame:
            self.summary.fixed_frame = self._frame(self.opt.fixed_frame)
            return
        children = {c for _, c in self._tf_edges}
        parents = {p for p, _ in self._tf_edges}
        frames = children | parents
        if "map" in frames or not frames:
            self.summary.fixed_frame = "map"
            return
        roots = sorted(parents - children)
        size = Counter()
        for r in roots:
            size[r] = sum(1 for f in frames if self._root_of(f) == r)
        self.summary.fixed_frame = max(roots, key=lambda r: (size[r], r == "odom", r)) if roots else "map"

    def _root_of(self, frame: str) -> str:
        parent = {c: p for p, c in self._tf_edges}
        seen = set()
        while frame in parent and frame not in seen:
            seen.add(frame)
            frame = parent[frame]
        return frame

    def _link_orphan_frames(self) -> None:
        """Frames with no TF path to the fixed frame are drawn as coincident with it (and reported)."""
        fixed = self.summary.fixed_frame
        fixed_root = self._root_of(fixed)
        orphans = sorted({self._root_of(f) for f in self._frames_used} - {fixed_root})
        for f in orphans:
            ent = self._entity(f"tf/_unlinked/{entity_name(f)}")
            self.rec.log(ent, self.rr.Transform3D(parent_frame=fixed, child_frame=f), static=True)
        if orphans:
            self.summary.warnings.append(
                f"frames without a TF path to {fixed}, drawn as coincident with it: {', '.join(orphans)}"
            )

    def _send_tf(self) -> None:
        rr = self.rr
        for (parent, child), e in sorted(self._tf_edges.items()):
            ent = self._entity(f"tf/{entity_name(child)}")
            xyz = np.asarray(e["xyz"], dtype=np.float64)
            q = np.asarray(e["q"], dtype=np.float64)
            if e["static"]:
                self.rec.log(
                    ent,
                    rr.Transform3D(
                        translation=xyz[-1],
                        quaternion=rr.Quaternion(xyzw=q[-1]),
                        parent_frame=parent,
                        child_frame=child,
                    ),
                    static=True,
                )
            else:
                n = len(xyz)
                self.rec.send_columns(
                    ent,
                    indexes=[self._tcol(e["t"])],
                    columns=rr.Transform3D.columns(
                        translation=xyz, quaternion=q, parent_frame=[parent] * n, child_frame=[child] * n
                    ),
                )
            axes = self._entity(f"tf/{entity_name(child)}/axes")
            self._set_frame(axes, child)
            self.rec.log(axes, rr.TransformAxes3D(0.15, show_frame=True), static=True)

    def _send_trajectories(self) -> None:
        rr = self.rr
        for topic, o in sorted(self._odom.items()):
            if not o.t:
                continue
            role = _traj_role(topic)
            color = COLORS[role]
            base = f"trajectories/{entity_name(topic)}"
            xyz = np.asarray(o.xyz, dtype=np.float32)
            line = self._entity(f"{base}/path")
            self._set_frame(line, o.frame)
            self.rec.log(line, rr.LineStrips3D([xyz], radii=0.01, colors=[color], labels=[topic]), static=True)
            pose = self._entity(f"{base}/pose")
            self._set_frame(pose, o.frame)
            self.rec.send_columns(
                pose,
                indexes=[self._tcol(o.t)],
                columns=rr.Arrows3D.columns(origins=xyz, vectors=yaw_vectors(np.asarray(o.q), 0.3).astype(np.float32)),
            )
            self.rec.log(pose, rr.Arrows3D.from_fields(colors=[color], radii=0.015), static=True)
            self.summary.drawn[topic] = base

    def _send_paths(self) -> None:
        rr = self.rr
        for topic, items in sorted(self._paths.items()):
            if not items:
                continue
            ent = self._entity(f"plans/{entity_name(topic)}")
            self._set_frame(ent, items[0][1])
            self.rec.send_columns(
                ent,
                indexes=[self._tcol([i[0] for i in items])],
                columns=rr.LineStrips3D.columns(strips=[i[2][:, :3] for i in items]),
            )
            self.rec.log(ent, rr.LineStrips3D.from_fields(colors=[COLORS["plan"]], radii=0.02), static=True)
            if len({i[1] for i in items}) > 1:
                self.summary.warnings.append(f"{topic}: frame_id changes; drawn in {items[0][1]}")
            self.summary.drawn.setdefault(topic, ent)

    def _send_goals(self) -> None:
        rr = self.rr
        for topic, goals in sorted(self._goals.items()):
            ent = self._entity(f"goals/{entity_name(topic)}")
            self._set_frame(ent, goals[0][1])
            labels = _goal_labels(goals, self._events)
            for k, (t, _, _, _) in enumerate(goals):
                self._set_time(t)
                origins = np.array([g[2] for g in goals[: k + 1]], dtype=np.float32)
                vecs = yaw_vectors(np.array([g[3] for g in goals[: k + 1]]), 0.5).astype(np.float32)
                self.rec.log(
                    ent,
                    rr.Arrows3D(
                        origins=origins, vectors=vecs, labels=labels[: k + 1], colors=[COLORS["goal"]], radii=0.03
                    ),
                )
            self.summary.drawn[topic] = ent
        for topic, items in sorted(self._waypoints.items()):
            ent = self._entity(f"goals/{entity_name(topic)}")
            self._set_frame(ent, items[0][1])
            for t, _, xyz, q in items:
                self._set_time(t)
                labels = [f"wp {i + 1}" for i in range(len(xyz))]
                self.rec.log(
                    ent,
                    rr.Arrows3D(
                        origins=xyz,
                        vectors=yaw_vectors(q, 0.5).astype(np.float32),
                        labels=labels,
                        colors=[COLORS["waypoint"]],
                        radii=0.03,
                    ),
                )
            self.summary.drawn[topic] = ent

    def _gridmap(self, cells: np.ndarray, res: float, origin_xyz, q_xyzw):
        rr = self.rr
        h, w = cells.shape
        return rr.GridMap(
            data=np.ascontiguousarray(cells).view(np.uint8).tobytes(),
            format=rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U8"),
            cell_size=res,
            translation=[float(v) for v in origin_xyz],
            quaternion=rr.Quaternion(xyzw=[float(v) for v in q_xyzw]),
            colormap=rr.components.Colormap.RvizMap,
        )

    def _send_grids(self) -> None:
        for topic, entry in sorted(self._grid_pending.items()):
            self._grids[topic].append(entry)
        self._grid_pending.clear()
        for topic, grids in sorted(self._grids.items()):
            ent = self._entity(f"grids/{entity_name(topic)}")
            self._set_frame(ent, grids[0][1])
            for t, _, cells, res, xyz, q in grids:
                self._set_time(t)
                self.rec.log(ent, self._gridmap(cells, res, xyz, q))
            self.summary.drawn[topic] = ent

    # -------------------------------------------------------------- top-down 2D view

    def _top_grid_source(self) -> tuple[str, list] | None:
        """The grid drawn in the 2D view: replay map, /map, a global costmap, any grid, in that order."""
        if self._static_grid is not None:
            name, cells, res, ox, oy = self._static_grid
            return name, [(0, self.summary.fixed_frame, cells, res, (ox, oy, 0.0), (0, 0, 0, 1))]
        order = sorted(self._grids, key=lambda k: (k != "replay/map", k != "/map", "global" not in k, k))
        for topic in order:
            if self._grids[topic]:
                return topic, self._grids[topic]
        return None

    def _to_fixed(self, frame: str, stamp: int | None) -> np.ndarray | None:
        """Frame -> fixed frame at a stamp; a frame of another TF tree counts as coincident with it."""
        fixed = self.summary.fixed_frame
        try:
            return self.tf.lookup(fixed, frame, stamp)
        except TransformError:
            root = self._root_of(frame)
            if root == self._root_of(fixed):
                return None
            try:
                return self.tf.lookup(root, frame, stamp)
            except TransformError:
                return None

    def _send_top(self) -> None:
        rr = self.rr
        fixed = self.summary.fixed_frame
        base = next((f for f in ("base_footprint", "base_link") if f in set(self.tf.frames())), None)
        # scans into the fixed frame
        scans2d: dict[str, tuple[list[int], list[np.ndarray]]] = {}
        poses: list[tuple[int, np.ndarray]] = []
        # the footprint is drawn at the times of the busiest scan topic
        main_scan = max(sorted(self._scans), key=lambda k: len(self._scans[k].t), default=None)
        for topic, s in sorted(self._scans.items()):
            ts, pts = [], []
            for t, stamp, p in zip(s.t, s.stamps, s.pts):
                m = self._to_fixed(s.frame, stamp)
                if m is None:
                    self.summary.skipped[f"no TF {fixed} <- {s.frame} for 2D scan on {topic}"] += 1
                    continue
                ts.append(t)
                pts.append(p.astype(np.float64) @ m[:2, :2].T + m[:2, 3])
                if base is not None and topic == main_scan:
                    mb = self._to_fixed(base, stamp)
                    if mb is not None:
                        poses.append((t, mb))
            if ts:
                scans2d[topic] = (ts, pts)
        trajs2d = {}
        for topic, o in sorted(self._odom.items()):
            if not o.t:
                continue
            m = self._to_fixed(o.frame, None)  # the latest transform of the odometry frame
            if m is None:
                continue
            xyz = np.asarray(o.xyz)
            trajs2d[topic] = xyz[:, :2] @ m[:2, :2].T + m[:2, 3]
        plans2d = {}
        for topic, items in sorted(self._paths.items()):
            frame = items[0][1]
            m = np.eye(4) if frame == fixed else self._to_fixed(frame, None)
            if m is not None:
                plans2d[topic] = [(t, xyz[:, :2].astype(np.float64) @ m[:2, :2].T + m[:2, 3]) for t, _, xyz in items]
        grid = self._top_grid_source()
        if grid is None and not scans2d and not trajs2d:
            return
        # the canvas: the grid's extent, else everything drawn plus a margin
        if grid is not None:
            name, grids = grid
            boxes = []
            for _, frame, cells, res, (ox, oy, _), q in grids:
                h, w = cells.shape
                boxes.append((ox, oy, ox + w * res, oy + h * res))
            b = np.array(boxes)
            canvas = Canvas.around(
                b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max(), grids[-1][3], self.opt.max_canvas_px
            )
            self.summary.grid_source = name
        else:
            allxy = [np.concatenate(p) for _, p in scans2d.values() if p] + list(trajs2d.values())
            xy = np.concatenate(allxy) if allxy else np.zeros((1, 2))
            lo, hi = xy.min(axis=0) - 1.0, xy.max(axis=0) + 1.0
            canvas = Canvas.around(lo[0], lo[1], hi[0], hi[1], 0.05, self.opt.max_canvas_px)
        self.summary.has_top = True
        ent = self._entity("top/grid")
        if grid is not None:
            name, grids = grid
            for t, frame, cells, res, (ox, oy, _), q in grids:
                if abs(messages.yaw_from_quat(q)) > 1e-6:
                    self.summary.warnings.append(f"{name}: rotated grid origin drawn unrotated in the 2D view")
                img = canvas.paste(grid_gray(cells), ox, oy, res)
                if name.startswith("replay/") and len(grids) == 1 and t == 0:
                    self.rec.log(ent, rr.Image(img, color_model="L", draw_order=-10.0), static=True)
                else:
                    self._set_time(t)
                    self.rec.log(ent, rr.Image(img, color_model="L", draw_order=-10.0))
        else:
            self.rec.log(
                ent,
                rr.Image(np.full((canvas.height, canvas.width), 205, np.uint8), color_model="L", draw_order=-10.0),
                static=True,
            )
        for topic, (ts, pts) in scans2d.items():
            e = self._entity(f"top/scans/{entity_name(topic)}")
            px = canvas.to_px(np.concatenate(pts)) if pts else np.zeros((0, 2), np.float32)
            self.rec.send_columns(
                e, indexes=[self._tcol(ts)], columns=rr.Points2D.columns(positions=px).partition([len(p) for p in pts])
            )
            self.rec.log(e, rr.Points2D.from_fields(radii=1.0, colors=[COLORS["scan"]], draw_order=5.0), static=True)
        for topic, xy in trajs2d.items():
            e = self._entity(f"top/trajectories/{entity_name(topic)}")
            self.rec.log(
                e,
                rr.LineStrips2D([canvas.to_px(xy)], colors=[COLORS[_traj_role(topic)]], labels=[topic], draw_order=3.0),
                static=True,
            )
        for topic, items in plans2d.items():
            e = self._entity(f"top/plans/{entity_name(topic)}")
            self.rec.send_columns(
                e,
                indexes=[self._tcol([t for t, _ in items])],
                columns=rr.LineStrips2D.columns(strips=[canvas.to_px(xy) for _, xy in items]),
            )
            self.rec.log(e, rr.LineStrips2D.from_fields(colors=[COLORS["plan"]], draw_order=4.0), static=True)
        if not poses and base is None:
            # no TF to the robot: the footprint follows the first odometry in the fixed frame
            for topic, o in sorted(self._odom.items()):
                if o.frame == fixed and o.t:
                    step = max(1, len(o.t) // max(1, int((o.t[-1] - o.t[0]) / 1e8) or 1))
                    for i in range(0, len(o.t), step):
                        poses.append((o.t[i], messages.make_transform(o.xyz[i], o.q[i])))
                    break
        if poses:
            fp = np.array(tuple(self.footprint) + (self.footprint[0],), dtype=np.float64)
            strips = [canvas.to_px(fp @ m[:2, :2].T + m[:2, 3]) for _, m in poses]
            e = self._entity("top/footprint")
            self.rec.send_columns(
                e, indexes=[self._tcol([t for t, _ in poses])], columns=rr.LineStrips2D.columns(strips=strips)
            )
            self.rec.log(
                e, rr.LineStrips2D.from_fields(colors=[COLORS["footprint"]], radii=1.0, draw_order=6.0), static=True
            )

    # -------------------------------------------------------------- plots and events

    def _scalars(self, ent: str, t: list[int] | np.ndarray, v: np.ndarray, name: str, color=None) -> None:
        rr = self.rr
        ent = self._entity(ent)
        self.rec.send_columns(
            ent, indexes=[self._tcol(t)], columns=rr.Scalars.columns(scalars=np.asarray(v, dtype=np.float64))
        )
        self.rec.log(ent, rr.SeriesLines(names=name, colors=[color] if color else None), static=True)

    def _send_plots(self) -> None:
        chain = [t for t in VELOCITY_CHAIN if t in self._twists] + sorted(
            t for t in self._twists if t not in VELOCITY_CHAIN
        )
        for topic in chain:
            arr = np.array(self._twists[topic], dtype=np.float64)
            t = arr[:, 0].astype(np.int64)
            name = entity_name(topic)
            color = CHAIN_COLORS.get(topic)
            self._scalars(f"plots/cmd_vel/vx/{name}", t, arr[:, 1], topic, color)
            if np.any(arr[:, 2] != 0):
                self._scalars(f"plots/cmd_vel/vy/{name}", t, arr[:, 2], topic, color)
            self._scalars(f"plots/cmd_vel/wz/{name}", t, arr[:, 3], topic, color)
            self.summary.drawn[topic] = f"plots/cmd_vel/*/{name}"
        for topic, o in sorted(self._odom.items()):
            if o.speed:
                self._scalars(
                    f"plots/speed/{entity_name(topic)}", o.t, np.array(o.speed), topic, COLORS[_traj_role(topic)]
                )
        truth = next((k for k in sorted(self._odom) if "ground_truth" in k), None)
        if truth is not None:
            gt = self._odom[truth]
            for topic, o in sorted(self._odom.items()):
                if topic == truth or not o.t or "trajectory_tum" in topic:
                    continue
                t, d = drift_series(np.array(o.t), np.array(o.xyz), np.array(gt.t), np.array(gt.xyz))
                if len(t):
                    self._scalars(
                        f"plots/metrics/drift/{entity_name(topic)}",
                        t,
                        d,
                        f"{topic} drift (m)",
                        COLORS[_traj_role(topic)],
                    )
        for topic, rows in sorted(self._imu.items()):
            arr = np.array(rows, dtype=np.float64)
            t = arr[:, 0].astype(np.int64)
            self._scalars(f"plots/imu/{entity_name(topic)}/wz", t, arr[:, 1], f"{topic} angular z")
            self._scalars(f"plots/imu/{entity_name(topic)}/ax", t, arr[:, 2], f"{topic} accel x")
            self.summary.drawn[topic] = f"plots/imu/{entity_name(topic)}"

    def _send_events(self) -> None:
        rr = self.rr
        for topic, rows in sorted(self._texts.items()):
            ent = self._entity(f"text/{entity_name(topic)}")
            self.rec.send_columns(
                ent,
                indexes=[self._tcol([r[0] for r in rows])],
                columns=rr.TextLog.columns(text=[r[1] for r in rows], level=[r[2] for r in rows]),
            )
            self.summary.drawn[topic] = ent
        if not self._events:
            return
        ent = self._entity("events")
        ev = sorted(self._events, key=lambda e: e[0])
        self.rec.send_columns(
            ent,
            indexes=[self._tcol([e[0] for e in ev])],
            columns=rr.TextLog.columns(text=[e[1] for e in ev], level=[e[2] for e in ev]),
        )


def _traj_role(topic: str) -> str:
    if topic.startswith("replay"):
        return "replay"
    if "ground_truth" in topic:
        return "ground_truth"
    return "estimate2" if topic.endswith("/Odometry") else "estimate"


def _goal_labels(goals: list, events: list[tuple[int, str, str]]) -> list[str]:
    """'goal N' plus the detail of the goal event that follows it within a second, if any."""
    labels = []
    for i, (t, _, xyz, _) in enumerate(goals):
        label = f"goal {i + 1} ({xyz[0]:.2f}, {xyz[1]:.2f})"
        for te, text, _ in events:
            if t <= te <= t + 1_000_000_000 and text.lower().startswith("goal") and ": " in text:
                label = f"goal {i + 1}: {text.split(': ', 1)[1]}"
                break
        labels.append(label)
    return labels


def _height_colors(z: np.ndarray) -> np.ndarray:
    if len(z) == 0:
        return np.zeros((0, 3), np.uint8)
    lo, hi = np.percentile(z, [2, 98])
    a = np.clip((z - lo) / max(hi - lo, 1e-6), 0, 1)
    return np.stack([255 * a, 80 + 100 * (1 - abs(a - 0.5) * 2), 255 * (1 - a)], axis=1).astype(np.uint8)


# ---------------------------------------------------------------- blueprint


def make_blueprint(summary: ViewSummary):
    """The default layout: 3D view | (2D top-down, time series tabs, events)."""
    import rerun.blueprint as rrb

    ents = summary.entities

    def has(prefix: str) -> bool:
        return any(e == prefix or e.startswith(prefix + "/") for e in ents)

    view3d = rrb.Spatial3DView(
        name=f"3D ({summary.fixed_frame})",
        origin="/",
        contents=["+ /**", "- /top/**", "- /plots/**", "- /events/**", "- /text/**"],
        spatial_information=rrb.SpatialInformation(target_frame=summary.fixed_frame, show_axes=True),
    )
    right = []
    if has("/top"):
        right.append(rrb.Spatial2DView(name="top-down", origin="/top"))
    tabs = []
    for sub, title in (("vx", "cmd vx (m/s)"), ("vy", "cmd vy (m/s)"), ("wz", "cmd wz (rad/s)")):
        if has(f"/plots/cmd_vel/{sub}"):
            tabs.append(rrb.TimeSeriesView(name=title, origin=f"/plots/cmd_vel/{sub}"))
    for sub, title in (("speed", "speed (m/s)"), ("metrics", "metrics"), ("imu", "IMU")):
        if has(f"/plots/{sub}"):
            tabs.append(rrb.TimeSeriesView(name=title, origin=f"/plots/{sub}"))
    if tabs:
        right.append(rrb.Tabs(*tabs, name="time series"))
    if has("/events"):
        right.append(rrb.TextLogView(name="events", origin="/events"))
    if has("/text"):
        right.append(rrb.TextLogView(name="text topics", origin="/text"))
    layout = rrb.Horizontal(view3d, rrb.Vertical(*right), column_shares=[3, 2]) if right else view3d
    return rrb.Blueprint(layout, rrb.TimePanel(timeline=TIMELINE), collapse_panels=False)


# ---------------------------------------------------------------- entry points


def recording_id(reader: LogReader) -> str:
    """A recording id that depends on the log's content summary only (same log -> same id)."""
    import hashlib

    key = f"{reader.start_ns}:{reader.end_ns}:{reader.message_count}:" + ",".join(
        f"{t.name}={t.typename}#{t.count}" for t in sorted(reader.topics.values(), key=lambda t: t.name)
    )
    return "navlog-" + hashlib.sha256(key.encode()).hexdigest()[:16]


def build_view(
    reader: LogReader, rec: Any, *, replay_dir: Path | None = None, options: ViewOptions | None = None
) -> ViewSummary:
    """Draw a log (and a replay output folder) into a RecordingStream whose sink is already set."""
    rec.set_log_time_enabled(False) if hasattr(rec, "set_log_time_enabled") else None
    rec.set_log_tick_enabled(False) if hasattr(rec, "set_log_tick_enabled") else None
    b = ViewBuilder(rec, options)
    b.add_log(reader)
    if replay_dir is not None:
        b.add_replay_dir(Path(replay_dir))
    if b.summary.messages == 0 and not b.summary.entities:
        have = ", ".join(f"{t.name} ({t.typename})" for t in reader.topics.values()) or "no topics"
        raise LogError(f"{reader.path}: nothing to draw: the log has {have}")
    return b.finish()


def new_recording(reader: LogReader):
    import rerun as rr

    return rr.RecordingStream("navlog", recording_id=recording_id(reader))


def save_view(
    log_path: Path | str,
    out: Path | str,
    *,
    replay_dir: Path | str | None = None,
    options: ViewOptions | None = None,
    force: bool = False,
    recover: bool = False,
) -> ViewSummary:
    """Convert a log to an .rrd file; the file appears under its name only when complete."""
    out = Path(out)
    if out.suffix != ".rrd":
        raise NavlogError(f"{out}: the output must end in .rrd")
    if out.exists() and not force:
        raise NavlogError(f"{out}: already exists; choose another name or pass --force to overwrite it")
    if not out.parent.is_dir():
        raise NavlogError(f"{out.parent}: output folder does not exist")
    tmp = out.with_name(f".{out.name}.{os.getpid()}.part")
    rec = None
    try:
        with open_log(log_path, recover=recover) as reader:
            rec = new_recording(reader)
            rec.save(str(tmp))
            summary = build_view(reader, rec, replay_dir=Path(replay_dir) if replay_dir else None, options=options)
        rec.flush()
        rec.disconnect()
        rec = None
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise NavlogError(f"{out}: Rerun wrote nothing")
        os.replace(tmp, out)
        return summary
    finally:
        if rec is not None:
            try:
                rec.disconnect()
            except Exception:
                pass
        tmp.unlink(missing_ok=True)


def stream_view(
    log_path: Path | str,
    *,
    spawn: bool = False,
    connect: str | None = None,
    replay_dir: Path | str | None = None,
    options: ViewOptions | None = None,
    recover: bool = False,
    flush_timeout_s: float = 30.0,
) -> ViewSummary:
    """Send a log to a viewer: a newly spawned one, or one listening at ``connect``."""
    with open_log(log_path, recover=recover) as reader:
        rec = new_recording(reader)
        if spawn:
            rec.spawn()
        else:
            rec.connect_grpc(connect)
        summary = build_view(reader, rec, replay_dir=Path(replay_dir) if replay_dir else None, options=options)
    try:
        rec.flush(timeout_sec=flush_timeout_s)
    except Exception as exc:
        rec.disconnect()
        where = "the spawned viewer" if spawn else (connect or "rerun+http://127.0.0.1:9876/proxy")
        raise NavlogError(
            f"no Rerun viewer took the recording at {where} within {flush_timeout_s:g} s ({exc})"
        ) from None
    rec.disconnect()
    return summary
