"""A and B overlaid in one Rerun file (``navlog diff --rrd``), for looking at what moved.

One layout, in the spirit of ``navlog view``'s default and with its colours (``view.context.COLORS``,
Okabe-Ito): A, the baseline, is blue; B, the candidate, vermillion; what differs is yellow. Drawn in
the ``map`` frame:

- 3D: the occupied cells of A and B (``a/map``, ``b/map``: B's smaller dots over A's, so cells both
  hold show both colours) and the cells whose class changed (``diff/map_changed``, yellow, on top);
  the point maps (``a/map_pcd``, ``b/map_pcd``); the trajectories (``a/trajectory``,
  ``b/trajectory``, each labelled once) and, where B's position lies more than ``DIVERGENCE_M`` from
  A's at the same time, yellow segments joining them (``diff/divergence``); the plans of a planner
  replay over time (``a/plans/...``, ``b/plans/...``);
- top-down (``top/``): one image of the common map canvas (occupied in both black, only in A blue,
  only in B vermillion, other class changes yellow), the trajectories and divergence segments;
- plots (``plots/``) on the ``sim_time`` timeline, each title with its unit: the distance between the
  trajectories, and each command topic's vx and wz for A, B and B - A;
- the report as text (``diff/report``).

The 3D camera starts on the first divergence of the trajectories, else on the first changed cell,
else on A's first pose. ``build_overlay`` returns what it drew as plain data (``OverlayPlan``: every
entity with its colour, the camera, the plots) for tests; ``overlay_blueprint`` lays it out. Replay
output folders and single map/PCD/TUM files are drawn; logs are not (``navlog view`` draws a log).
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.analysis.diff.core import input_kind
from navlog.analysis.diff.grids import common_canvas
from navlog.analysis.diff.report import format_report
from navlog.analysis.diff.result import DiffReport
from navlog.analysis.metrics.maps import classify
from navlog.analysis.view.blueprint import CAMERA_BACK_M, CAMERA_UP_M, PlotView, time_series_view, y_range
from navlog.analysis.view.context import COLORS, TIMELINE, entity_name
from navlog.analysis.view.grids import crop_known, grid_gray
from navlog.analysis.view.topdown import TOP_MARGIN_M
from navlog.errors import NavlogError
from navlog.replay.occupancy_map import OccupancyMap

__all__ = ["OverlayPlan", "build_overlay", "overlay_blueprint", "save_overlay"]

# A, B and their differences in the colours of navlog view's roles: blue (an estimate), vermillion
# (the local plan) and yellow (the scan): told apart by readers with any common colour-vision deficiency
ROLES = {"a": "estimate2", "b": "local_plan", "changed": "scan", "both": "cloud"}
COLORS_DIFF = {k: COLORS[role] for k, role in ROLES.items()}
LABELS = {"a": "A (baseline)", "b": "B (candidate)"}
DIVERGENCE_M = 0.05  # trajectories further apart than this at the same time are drawn joined in yellow
Z_LIFT = {"a": 0.0, "b": 0.01, "changed": 0.02}  # m: B's cells over A's, changes over both
OCCUPIED_BOTH_GRAY = 0  # top-down: occupied in both as map_server draws occupied cells
COMMAND_PLOTS = (("vx", 0, "forward vx (m/s)"), ("wz", 2, "turn wz (rad/s)"))


@dataclass
class OverlayPlan:
    """What the overlay drew: entity -> colour, the camera, the top-down bounds, the plots."""

    colors: dict[str, tuple[int, int, int]] = field(default_factory=dict)
    camera_target: tuple[float, float, float] | None = None
    camera_position: tuple[float, float, float] | None = None
    top_bounds: tuple[float, float, float, float] | None = None  # u0, u1, v0, v1 (px)
    plots: list[PlotView] = field(default_factory=list)
    focus: str = ""  # what the camera starts on

    def has_3d(self) -> bool:
        """True when something is drawn for the 3D view (not only plots and text)."""
        return any(not e.startswith(("top/", "plots/", "diff/report")) for e in self.colors)

    def focus_on(self, what: str, xy: np.ndarray, heading: float = 0.0) -> None:
        """Point the camera at (x, y) unless something earlier in the order already took it."""
        if self.camera_target is not None:
            return
        x, y = float(xy[0]), float(xy[1])
        self.focus = what
        self.camera_target = (x, y, 0.0)
        self.camera_position = (
            x - CAMERA_BACK_M * math.cos(heading),
            y - CAMERA_BACK_M * math.sin(heading),
            CAMERA_UP_M,
        )


class _Drawer:
    def __init__(self, rec: Any) -> None:
        import rerun as rr

        self.rr, self.rec = rr, rec
        self.plan = OverlayPlan()
        self.offset_ns = 0
        self.canvas: OccupancyMap | None = None  # the top-down image's lattice
        self.trajs: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # side -> (times ns, xyz)
        self.changed_xy: np.ndarray | None = None  # a changed cell (the camera's last resort)

    def log(self, ent: str, color: tuple[int, int, int] | None, archetype: Any, static: bool = True) -> None:
        if color is not None:
            self.plan.colors[ent] = color
        self.rec.log(ent, archetype, static=static)

    def to_px(self, xy: np.ndarray) -> np.ndarray:
        c = self.canvas
        assert c is not None
        top = c.origin[1] + c.data.shape[0] * c.resolution
        return np.stack([(xy[:, 0] - c.origin[0]) / c.resolution, (top - xy[:, 1]) / c.resolution], axis=1)

    def time(self, t_ns: np.ndarray) -> Any:
        d = (np.asarray(t_ns, dtype=np.int64) - self.offset_ns).astype("timedelta64[ns]")
        return self.rr.TimeColumn(TIMELINE, duration=d)

    def series(self, ent: str, t_ns: np.ndarray, v: np.ndarray, name: str, color: tuple[int, int, int]) -> None:
        rr = self.rr
        self.rec.send_columns(ent, indexes=[self.time(t_ns)], columns=rr.Scalars.columns(scalars=v))
        width = 3.0 if ent.endswith("/a") else 1.5  # A wider than B: where they agree, A borders B
        self.log(ent, color, rr.SeriesLines(names=name, colors=[color], widths=width))

    def plot(self, title: str, ents: list[str], values: list[np.ndarray]) -> None:
        finite = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.zeros(0)
        lo, hi = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 0.0)
        self.plan.plots.append(PlotView(title, tuple("/" + e for e in ents), y_range(lo, hi)))


def _files(path: Path, suffix: str) -> Path | None:
    if path.is_file():
        return path if path.suffix == suffix else None
    found = sorted(path.glob(f"*{suffix}"))
    return found[0] if found else None


def _cells(grid: OccupancyMap, mask: np.ndarray, z: float) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    x, y = grid.cell_to_world(cols, rows)
    return np.stack([x, y, np.full_like(x, z)], axis=1).reshape(-1, 3)


def _draw_maps(d: _Drawer, a: Path, b: Path) -> None:
    from navlog.replay.io.map_server import load_map

    rr = d.rr
    ca, cb = common_canvas(load_map(a), load_map(b))
    occ_a, free_a = classify(ca.data)
    occ_b, free_b = classify(cb.data)
    changed = (occ_a != occ_b) | (free_a != free_b)
    res = ca.resolution
    for name, mask, key, radius in (
        ("a/map", occ_a, "a", res / 2),
        ("b/map", occ_b, "b", res * 0.3),
        ("diff/map_changed", changed, "changed", res * 0.2),
    ):
        color = COLORS_DIFF[key]
        d.log(name, color, rr.Points3D(_cells(ca, mask, Z_LIFT[key]), colors=[color], radii=radius))
    # top-down: one RGB image, rows flipped so that north is up
    gray = grid_gray(ca.data)
    img = np.repeat(gray[:, :, None], 3, axis=2)
    img[occ_a & occ_b] = OCCUPIED_BOTH_GRAY
    img[changed] = COLORS_DIFF["changed"]
    img[occ_a & ~occ_b] = COLORS_DIFF["a"]
    img[occ_b & ~occ_a] = COLORS_DIFF["b"]
    d.canvas = ca
    d.log("top/map", None, rr.Image(img[::-1].copy(), color_model="RGB", draw_order=-10.0))
    known = np.where((ca.data >= 0) | (cb.data >= 0), 0, -1).astype(np.int8)
    crop, (kx, ky, _) = crop_known(known, res, (ca.origin[0], ca.origin[1], 0.0), (0, 0, 0, 1), TOP_MARGIN_M)
    corners = d.to_px(np.array([[kx, ky], [kx + crop.shape[1] * res, ky + crop.shape[0] * res]]))
    d.plan.top_bounds = (
        float(corners[:, 0].min()),
        float(corners[:, 0].max()),
        float(corners[:, 1].min()),
        float(corners[:, 1].max()),
    )
    if changed.any():
        d.changed_xy = _cells(ca, changed, 0.0)[0]


def _draw_pcds(d: _Drawer, a: Path, b: Path) -> None:
    from navlog.replay.io.pcd import read_pcd

    for side, path in (("a", a), ("b", b)):
        color = COLORS_DIFF[side]
        d.log(f"{side}/map_pcd", color, d.rr.Points3D(read_pcd(path), colors=[color], radii=0.01))


def _draw_tums(d: _Drawer, a: Path, b: Path) -> None:
    from navlog.replay.io.tum import read_tum

    for side, path in (("a", a), ("b", b)):
        tum = read_tum(path)
        d.trajs[side] = (tum.times_ns, np.asarray(tum.positions, dtype=np.float64))


def _send_trajectories(d: _Drawer) -> None:
    """Both trajectories, their divergence (3D, top-down, a plot) and the camera on its first place."""
    rr = d.rr
    for side, (_, xyz) in d.trajs.items():
        color = COLORS_DIFF[side]
        radius = 0.025 if side == "a" else 0.012  # B inside A where they agree
        d.log(f"{side}/trajectory", color, rr.LineStrips3D([xyz], colors=[color], radii=radius, labels=[LABELS[side]]))
        if d.canvas is not None:
            order = 3.0 if side == "a" else 3.5  # B over A: where they agree, B shows
            width = rr.Radius.ui_points(3.0 if side == "a" else 1.5)
            strip = rr.LineStrips2D([d.to_px(xyz[:, :2])], colors=[color], radii=width, draw_order=order)
            d.log(f"top/{side}/trajectory", color, strip)
    if len(d.trajs) < 2:
        return
    (ta, pa), (tb, pb) = d.trajs["a"], d.trajs["b"]
    inside = (ta >= tb[0]) & (ta <= tb[-1])
    t, pa = ta[inside], pa[inside]
    if len(t) == 0 or len(tb) < 2:
        return
    pb = np.stack([np.interp(t.astype(np.float64), tb.astype(np.float64), pb[:, k]) for k in range(3)], axis=1)
    gap = np.linalg.norm(pa[:, :2] - pb[:, :2], axis=1)
    color = COLORS_DIFF["changed"]
    d.series("plots/trajectory/distance", t, gap, "|B - A| position (m)", color)
    d.plot("trajectory distance |B - A| (m)", ["plots/trajectory/distance"], [gap])
    apart = np.flatnonzero(gap > DIVERGENCE_M)
    if len(apart) == 0:
        return
    segments = [np.stack([pa[i], pb[i]]) for i in apart]
    d.log("diff/divergence", color, rr.LineStrips3D(segments, colors=[color], radii=0.01))
    if d.canvas is not None:
        px = [d.to_px(s[:, :2]) for s in segments]
        d.log(
            "top/diff/divergence",
            color,
            rr.LineStrips2D(px, colors=[color], radii=rr.Radius.ui_points(1.0), draw_order=4.0),
        )
    i = apart[0]
    step = pa[min(i + 1, len(pa) - 1)] - pa[max(i - 1, 0)]
    d.plan.focus_on("first divergence of the trajectories", pa[i], math.atan2(step[1], step[0]))


def _read_streams(path: Path) -> tuple[dict[str, list], dict[str, list]]:
    """Plans (topic -> [(t, xyz)]) and commands (topic -> [(t, vx, vy, wz)]) of a replay's log."""
    from navlog.analysis.view.plans import is_plan, path_positions
    from navlog.replay import messages
    from navlog.replay.io.formats import open_log

    plans: dict[str, list] = {}
    twists: dict[str, list] = {}
    with open_log(path) as reader:
        kinds = {n: i.typename for n, i in reader.topics.items()}
        wanted = [
            n
            for n, k in kinds.items()
            if (k.endswith("/Path") and is_plan(n)) or k.endswith(("/Twist", "/TwistStamped"))
        ]
        for env in reader.messages(sorted(wanted)):
            if kinds[env.topic].endswith("/Path"):
                plans.setdefault(env.topic, []).append((env.time_ns, path_positions(env.msg)))
            else:
                twists.setdefault(env.topic, []).append((env.time_ns, *messages.twist_values(env.msg)))
    return plans, twists


def _draw_streams(d: _Drawer, a: Path, b: Path) -> None:
    """Plans over time in 3D; for every command topic, vx and wz of A, B and B - A in one plot each."""
    rr = d.rr
    (plans_a, twists_a), (plans_b, twists_b) = _read_streams(a), _read_streams(b)
    for side, plans in (("a", plans_a), ("b", plans_b)):
        color = COLORS_DIFF[side]
        for topic, rows in sorted(plans.items()):
            ent = f"{side}/plans/{entity_name(topic)}"
            strips = rr.LineStrips3D.columns(strips=[xyz for _, xyz in rows])
            d.rec.send_columns(ent, indexes=[d.time(np.array([t for t, _ in rows]))], columns=strips)
            radius = 0.03 if side == "a" else 0.015  # B's thinner line inside A's where the plans agree
            d.log(ent, color, rr.LineStrips3D.from_fields(colors=[color], radii=radius))
    for topic in sorted(plans_a.keys() & plans_b.keys()):
        moved = [
            xa
            for (_, xa), (_, xb) in zip(plans_a[topic], plans_b[topic])
            if xa.shape != xb.shape or not np.allclose(xa, xb)
        ]
        if moved and len(moved[0]):
            step = moved[0][min(1, len(moved[0]) - 1)] - moved[0][0]
            d.plan.focus_on(f"first {topic} that moved", moved[0][0], math.atan2(step[1], step[0]))
    for topic in sorted(twists_a.keys() & twists_b.keys()):
        ra, rb = np.array(twists_a[topic], dtype=np.float64), np.array(twists_b[topic], dtype=np.float64)
        ta, tb = ra[:, 0].astype(np.int64), rb[:, 0].astype(np.int64)
        name = entity_name(topic)
        for comp, col, unit_title in COMMAND_PLOTS:
            va, vb = ra[:, 1 + col], rb[:, 1 + col]
            delta = np.interp(ta.astype(np.float64), tb.astype(np.float64), vb) - va
            ents = [f"plots/{name}/{comp}/{side}" for side in ("a", "b", "diff")]
            d.series(ents[0], ta, va, f"A {topic}", COLORS_DIFF["a"])
            d.series(ents[1], tb, vb, f"B {topic}", COLORS_DIFF["b"])
            d.series(ents[2], ta, delta, "B - A", COLORS_DIFF["changed"])
            d.plot(f"{topic} {unit_title}", ents, [va, vb, delta])


def build_overlay(report: DiffReport, rec: Any) -> OverlayPlan:
    """Draw the report's A and B into the recording stream ``rec``; returns what was drawn."""
    a, b = Path(report.a), Path(report.b)
    d = _Drawer(rec)
    d.log("diff/report", None, d.rr.TextDocument(format_report(report)))
    la, lb = (_files(a, ".mcap"), _files(b, ".mcap")) if a.is_dir() and b.is_dir() else (None, None)
    logs = (la, lb) if la is not None and lb is not None else None  # a replay's replay.mcap on both sides
    starts = []
    for suffix, draw in ((".yaml", _draw_maps), (".pcd", _draw_pcds), (".tum", _draw_tums)):
        fa, fb = _files(a, suffix), _files(b, suffix)
        if fa is not None and fb is not None:
            draw(d, fa, fb)
    starts += [int(t[0]) for t, _ in d.trajs.values() if len(t)]
    if logs is not None:
        from navlog.replay.io.formats import open_log

        for log in logs:
            with open_log(log) as reader:
                first = next(iter(reader.messages(decode=False)), None)
                if first is not None:
                    starts.append(first.time_ns)
    d.offset_ns = min(starts, default=0)
    _send_trajectories(d)
    if logs is not None:
        _draw_streams(d, *logs)
    if "a" in d.trajs and len(d.trajs["a"][1]):
        xyz = d.trajs["a"][1]
        step = xyz[min(1, len(xyz) - 1)] - xyz[0]
        heading = math.atan2(step[1], step[0])
        d.plan.focus_on("A's first pose", xyz[0], heading)
    if d.changed_xy is not None:
        d.plan.focus_on("first changed cell", d.changed_xy)
    return d.plan


def overlay_blueprint(plan: OverlayPlan) -> Any:
    """(3D | top-down) above (plots | report), as ``navlog view``'s default: panels collapsed."""
    import rerun.blueprint as rrb

    eye = None
    if plan.camera_target is not None:
        eye = rrb.EyeControls3D(position=plan.camera_position, look_target=plan.camera_target, eye_up=(0.0, 0.0, 1.0))
    view3d = rrb.Spatial3DView(
        name="3D (map): A blue, B vermillion, changes yellow",
        origin="/",
        contents=["+ /**", "- /top/**", "- /plots/**", "- /diff/report"],
        spatial_information=rrb.SpatialInformation(target_frame="tf#/", show_axes=True),
        eye_controls=eye,
    )
    views: list[rrb.Container | rrb.View] = [view3d] if plan.has_3d() else []
    if any(e.startswith("top/") for e in plan.colors):
        bounds = None
        if plan.top_bounds is not None:
            u0, u1, v0, v1 = plan.top_bounds
            bounds = rrb.VisualBounds2D(x_range=(u0, u1), y_range=(v0, v1))
        top2d = rrb.Spatial2DView(name="top-down: only A blue, only B vermillion", origin="/top", visual_bounds=bounds)
        views.append(top2d)
    report = rrb.TextDocumentView(name="diff report", origin="/diff/report")
    bottom: rrb.Container | rrb.View = report
    if plan.plots:
        plots = [time_series_view(p) for p in plan.plots]
        columns = len(plots) if len(plots) <= 3 else math.ceil(len(plots) / 2)
        bottom = rrb.Horizontal(rrb.Grid(*plots, grid_columns=columns), report, column_shares=[3, 2])
    if len(views) == 2:
        layout: rrb.Container | rrb.View = rrb.Vertical(
            rrb.Horizontal(*views, column_shares=[3, 2]), bottom, row_shares=[3, 2]
        )
    else:
        layout = rrb.Vertical(*views, bottom, row_shares=[3, 2]) if views else bottom
    return rrb.Blueprint(
        layout,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE, state="collapsed"),
        collapse_panels=False,
    )


def save_overlay(report: DiffReport, out: Path | str) -> Path:
    """Write the overlay of the report's A and B to ``out`` (.rrd); the file appears when complete."""
    import rerun as rr

    out = Path(out)
    if out.suffix != ".rrd":
        raise NavlogError(f"{out}: the Rerun file must end in .rrd")
    a = Path(report.a)
    if input_kind(a) == "log":
        raise NavlogError(f"{a}: --rrd draws replay output folders and map/PCD/TUM files; draw a log with navlog view")
    tmp = out.with_name(f".{out.name}.{os.getpid()}.part")
    out.parent.mkdir(parents=True, exist_ok=True)
    key = hashlib.sha256(f"{report.a}\n{report.b}".encode()).hexdigest()[:16]
    rec = rr.RecordingStream("navlog_diff", recording_id=f"navlog-diff-{key}")
    try:
        rec.save(str(tmp))
        plan = build_overlay(report, rec)
        rec.send_blueprint(overlay_blueprint(plan), make_active=True, make_default=True)
        rec.flush()
        rec.disconnect()
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out
