"""The top-down 2D view under ``top/``: a grid image, scans, trajectories, plans and the robot footprint.

Everything is drawn in the pixel space of one ``Canvas`` in the fixed frame: the extent of the
chosen grid (``Grids.top_source``), else of everything drawn plus a metre. The footprint follows
the robot's TF at the times of the busiest scan topic, else the first odometry in the fixed frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name
from navlog.analysis.view.grids import Grids, crop_known, grid_gray
from navlog.analysis.view.plans import Plans
from navlog.analysis.view.scans import Scans
from navlog.analysis.view.tf import TfTree
from navlog.analysis.view.trajectories import Trajectories
from navlog.errors import NavlogError
from navlog.replay.geometry import make_transform, yaw_from_quat

TOP_MARGIN_M = 0.5  # the 2D view opens on the grid's known cells plus this margin

# Go2 body outline (0.70 x 0.31 m) around base_footprint.
GO2_FOOTPRINT = ((0.35, 0.155), (0.35, -0.155), (-0.35, -0.155), (-0.35, 0.155))


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


def send_top(
    ctx: ViewContext,
    tf: TfTree,
    scans: Scans,
    trajectories: Trajectories,
    plans: Plans,
    grids: Grids,
    footprint: tuple[tuple[float, float], ...],
) -> tuple[str | None, list[tuple[int, np.ndarray]]]:
    """Draw the top-down view (nothing when there is no grid, no scan and no trajectory to draw).

    Returns the robot's base frame (None: no TF to it) and its poses in the fixed frame (log time,
    4x4), the ones the footprint is drawn at."""
    rr = ctx.rr
    summary = ctx.summary
    fixed = summary.fixed_frame
    base = tf.base_frame()
    # scans into the fixed frame
    scans2d: dict[str, tuple[list[int], list[np.ndarray]]] = {}
    poses: list[tuple[int, np.ndarray]] = []
    # the footprint is drawn at the times of the busiest scan topic
    main_scan = max(sorted(scans.topics), key=lambda k: len(scans.topics[k].t), default=None)
    for topic, s in sorted(scans.topics.items()):
        ts, pts = [], []
        for t, stamp, p in zip(s.t, s.stamps, s.pts):
            m = tf.to_fixed(s.frame, stamp)
            if m is None:
                summary.skipped[f"no TF {fixed} <- {s.frame} for 2D scan on {topic}"] += 1
                continue
            ts.append(t)
            pts.append(p.astype(np.float64) @ m[:2, :2].T + m[:2, 3])
            if base is not None and topic == main_scan:
                mb = tf.to_fixed(base, stamp)
                if mb is not None:
                    poses.append((t, mb))
        if ts:
            scans2d[topic] = (ts, pts)
    trajs2d = {}
    for topic, o in sorted(trajectories.topics.items()):
        if not o.t or trajectories.role(topic) == "replay_file":
            continue  # the file copy of an estimate drawn from the replay's own topic
        m = tf.to_fixed(o.frame, None)  # the latest transform of the odometry frame
        if m is None:
            continue
        xyz = np.asarray(o.xyz)
        trajs2d[topic] = xyz[:, :2] @ m[:2, :2].T + m[:2, 3]
    loops2d = {}
    for name, (frame, segments) in sorted(trajectories.loops.items()):
        m = np.eye(4) if frame == fixed else tf.to_fixed(frame, None)
        if m is not None and len(segments):
            loops2d[name] = segments[:, :, :2].astype(np.float64) @ m[:2, :2].T + m[:2, 3]
    plans2d = {}
    for topic, items in sorted(plans.topics.items()):
        frame = items[0][1]
        m = np.eye(4) if frame == fixed else tf.to_fixed(frame, None)
        if m is not None:
            plans2d[topic] = [(t, xyz[:, :2].astype(np.float64) @ m[:2, :2].T + m[:2, 3]) for t, _, xyz in items]
    if not poses and base is None:
        # no TF to the robot: the footprint follows the first odometry in the fixed frame
        for topic, o in sorted(trajectories.topics.items()):
            if o.frame == fixed and o.t:
                step = max(1, len(o.t) // max(1, int((o.t[-1] - o.t[0]) / 1e8) or 1))
                for i in range(0, len(o.t), step):
                    poses.append((o.t[i], make_transform(o.xyz[i], o.q[i])))
                break
    grid = grids.top_source()
    if grid is None and not scans2d and not trajs2d:
        return base, poses
    # the canvas: the grid's extent, else everything drawn plus a margin
    if grid is not None:
        name, grid_rows = grid
        boxes = []
        for _, frame, cells, res, (ox, oy, _), q in grid_rows:
            h, w = cells.shape
            boxes.append((ox, oy, ox + w * res, oy + h * res))
        b = np.array(boxes)
        canvas = Canvas.around(
            b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max(), grid_rows[-1][3], ctx.opt.max_canvas_px
        )
        summary.grid_source = name
        _, _, cells, res, origin, q = grid_rows[-1]
        known, (kx, ky, _) = crop_known(cells, res, origin, q, TOP_MARGIN_M)
        corners = canvas.to_px(np.array([[kx, ky], [kx + known.shape[1] * res, ky + known.shape[0] * res]]))
        summary.top_bounds = (
            float(corners[:, 0].min()),
            float(corners[:, 0].max()),
            float(corners[:, 1].min()),
            float(corners[:, 1].max()),
        )
    else:
        allxy = [np.concatenate(p) for _, p in scans2d.values() if p] + list(trajs2d.values())
        xy = np.concatenate(allxy) if allxy else np.zeros((1, 2))
        lo, hi = xy.min(axis=0) - 1.0, xy.max(axis=0) + 1.0
        canvas = Canvas.around(lo[0], lo[1], hi[0], hi[1], 0.05, ctx.opt.max_canvas_px)
    summary.has_top = True
    ent = ctx.entity("top/grid")
    if grid is not None:
        name, grid_rows = grid
        for t, frame, cells, res, (ox, oy, _), q in grid_rows:
            if abs(yaw_from_quat(q)) > 1e-6:
                summary.warnings.append(f"{name}: rotated grid origin drawn unrotated in the 2D view")
            img = canvas.paste(grid_gray(cells), ox, oy, res)
            if name.startswith("replay/") and len(grid_rows) == 1 and t == 0:
                ctx.rec.log(ent, rr.Image(img, color_model="L", draw_order=-10.0), static=True)
            else:
                ctx.set_time(t)
                ctx.rec.log(ent, rr.Image(img, color_model="L", draw_order=-10.0))
    else:
        ctx.rec.log(
            ent,
            rr.Image(np.full((canvas.height, canvas.width), 205, np.uint8), color_model="L", draw_order=-10.0),
            static=True,
        )
    for topic, (ts, pts) in scans2d.items():
        e = ctx.entity(f"top/scans/{entity_name(topic)}")
        px = canvas.to_px(np.concatenate(pts)) if pts else np.zeros((0, 2), np.float32)
        ctx.rec.send_columns(
            e, indexes=[ctx.time_column(ts)], columns=rr.Points2D.columns(positions=px).partition([len(p) for p in pts])
        )
        ctx.rec.log(
            e,
            rr.Points2D.from_fields(radii=rr.Radius.ui_points(1.5), colors=[COLORS["scan"]], draw_order=5.0),
            static=True,
        )
    for topic, xy in trajs2d.items():
        e = ctx.entity(f"top/trajectories/{entity_name(topic)}")
        ctx.rec.log(
            e,
            rr.LineStrips2D(
                [canvas.to_px(xy)],
                colors=[COLORS[trajectories.role(topic)]],
                radii=rr.Radius.ui_points(1.0),
                draw_order=3.0,
            ),
            static=True,
        )
    for topic, items in plans2d.items():
        e = ctx.entity(f"top/plans/{entity_name(topic)}")
        ctx.rec.send_columns(
            e,
            indexes=[ctx.time_column([t for t, _ in items])],
            columns=rr.LineStrips2D.columns(strips=[canvas.to_px(xy) for _, xy in items]),
        )
        role = "local_plan" if "local" in topic.lower() else "plan"
        ctx.rec.log(
            e,
            rr.LineStrips2D.from_fields(colors=[COLORS[role]], radii=rr.Radius.ui_points(1.5), draw_order=4.0),
            static=True,
        )
    for name, segments in loops2d.items():
        ctx.rec.log(
            ctx.entity(f"top/trajectories/{entity_name(name)}/loops"),
            rr.LineStrips2D(
                [canvas.to_px(seg) for seg in segments],
                colors=[COLORS["loop"]],
                radii=rr.Radius.ui_points(1.0),
                draw_order=3.5,
            ),
            static=True,
        )
    if poses:
        fp = np.array(tuple(footprint) + (footprint[0],), dtype=np.float64)
        strips = [canvas.to_px(fp @ m[:2, :2].T + m[:2, 3]) for _, m in poses]
        e = ctx.entity("top/footprint")
        ctx.rec.send_columns(
            e, indexes=[ctx.time_column([t for t, _ in poses])], columns=rr.LineStrips2D.columns(strips=strips)
        )
        ctx.rec.log(
            e,
            rr.LineStrips2D.from_fields(colors=[COLORS["footprint"]], radii=rr.Radius.ui_points(2.0), draw_order=6.0),
            static=True,
        )
    return base, poses
