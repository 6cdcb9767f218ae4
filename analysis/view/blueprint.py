"""The default Rerun blueprint, in the spirit of RViz's fixed-frame 3D view and Foxglove's 3D + plots
layouts: the 3D view beside the top-down view, every time series below them (none hidden in a tab; what
was commanded shares a plot with what the robot did, one plot per unit), and the events beside the
plots.

The 3D camera starts behind the robot's first pose at a few metres, looking at it (``follow``: it
tracks the robot as time plays). Each plot's title carries its unit and its y axis the range of its
data (``summary.plot_ranges``) plus a margin, always including zero. The blueprint and selection
panels start collapsed and the time panel shows only its playback bar, so the views get the window.
``plan_views`` lists the views as plain data (title, kind, entities) so that tests can read them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from navlog.analysis.view.context import TIMELINE
from navlog.analysis.view.options import ViewOptions, ViewSummary

CAMERA_BACK_M = 3.5  # the camera starts this far behind the robot ...
CAMERA_UP_M = 3.0  # ... and this high above it
NON_3D = ("/top", "/plots", "/events", "/text")

# (title, ((entity prefix, entity suffix), ...)) of the time-series views, in layout order: what was
# commanded beside what the robot did, in one plot per unit. A title is what is plotted and its unit,
# in at most TITLE_CHARS characters: a view's tab shows about 18 beside its buttons when four plots
# share a 1600 px window; the legend names each series (/cmd_vel, /odom, /imu/data yaw rate, ...).
PLOTS = (
    ("forward (m/s)", (("/plots/cmd_vel/vx/", ""), ("/plots/speed/", ""))),
    ("lateral (m/s)", (("/plots/cmd_vel/vy/", ""),)),
    ("turn (rad/s)", (("/plots/cmd_vel/wz/", ""), ("/plots/imu/", "/wz"))),
    ("odom drift (m)", (("/plots/metrics/", ""),)),
    ("accel x (m/s²)", (("/plots/imu/", "/ax"),)),
)
TITLE_CHARS = 16


@dataclass(frozen=True)
class PlotView:
    """One time-series view: its title, the series it shows and its y range."""

    title: str
    entities: tuple[str, ...]
    y_range: tuple[float, float]


@dataclass
class ViewPlan:
    """What the default blueprint shows."""

    fixed_frame: str
    camera_target: tuple[float, float, float] | None  # None: Rerun's default camera
    camera_position: tuple[float, float, float] | None
    follow: str  # the entity the camera tracks ("" : none)
    top_down: bool
    plots: list[PlotView] = field(default_factory=list)
    text_logs: list[tuple[str, str]] = field(default_factory=list)  # (title, origin)


def y_range(lo: float, hi: float) -> tuple[float, float]:
    """A readable y range for data in [lo, hi]: zero included, 10 % margin, at least 0.1 wide."""
    lo, hi = min(lo, 0.0), max(hi, 0.0)
    pad = max(0.1 * (hi - lo), 0.05)
    return (round(lo - pad if lo < 0 else lo, 6), round(hi + pad if hi > 0 or lo == 0 else hi, 6))


def plan_views(summary: ViewSummary, options: ViewOptions | None = None) -> ViewPlan:
    """The views the default blueprint holds for what the recording has."""
    opt = options or ViewOptions()
    ents = sorted(summary.entities)
    target = position = None
    if summary.robot_start is not None:
        x, y, z, yaw = summary.robot_start
        target = (x, y, z)
        position = (x - CAMERA_BACK_M * math.cos(yaw), y - CAMERA_BACK_M * math.sin(yaw), z + CAMERA_UP_M)
    plan = ViewPlan(
        fixed_frame=summary.fixed_frame,
        camera_target=target,
        camera_position=position,
        follow=summary.robot_entity if opt.follow else "",
        top_down=any(e == "/top" or e.startswith("/top/") for e in ents),
    )
    for title, parts in PLOTS:
        series = tuple(
            e
            for prefix, suffix in parts
            for e in ents
            if e.startswith(prefix) and e.endswith(suffix) and e in summary.plot_ranges
        )
        if series:
            lo = min(summary.plot_ranges[e][0] for e in series)
            hi = max(summary.plot_ranges[e][1] for e in series)
            plan.plots.append(PlotView(title, series, y_range(lo, hi)))
    if "/events" in summary.entities:
        plan.text_logs.append(("events", "/events"))
    if any(e.startswith("/text/") for e in ents):
        plan.text_logs.append(("text topics", "/text"))
    return plan


def time_series_view(plot: PlotView):
    """A plot under ``/plots`` with its title (unit included), series, legend and y range."""
    import rerun.blueprint as rrb

    return rrb.TimeSeriesView(
        name=plot.title,
        origin="/plots",
        contents=list(plot.entities),
        axis_y=rrb.ScalarAxis(range=plot.y_range),
        plot_legend=rrb.PlotLegend(visible=True),
    )


def make_blueprint(summary: ViewSummary, options: ViewOptions | None = None):
    """The default layout: (3D | top-down) above (plots | events); only views with content."""
    import rerun.blueprint as rrb

    opt = options or ViewOptions()
    plan = plan_views(summary, opt)
    eye = None
    if plan.camera_target is not None:
        eye = rrb.EyeControls3D(
            position=plan.camera_position,
            look_target=plan.camera_target,
            eye_up=(0.0, 0.0, 1.0),
            tracking_entity=plan.follow or None,
        )
    view3d = rrb.Spatial3DView(
        name=f"3D ({plan.fixed_frame})",
        origin="/",
        contents=["+ /**"] + [f"- {p}/**" for p in NON_3D],
        spatial_information=rrb.SpatialInformation(target_frame=plan.fixed_frame, show_axes=True),
        eye_controls=eye,
    )
    top: rrb.Container | rrb.View = view3d
    if plan.top_down:
        bounds = None
        if summary.top_bounds is not None:
            u0, u1, v0, v1 = summary.top_bounds
            bounds = rrb.VisualBounds2D(x_range=(u0, u1), y_range=(v0, v1))
        top = rrb.Horizontal(
            view3d, rrb.Spatial2DView(name="top-down", origin="/top", visual_bounds=bounds), column_shares=[3, 2]
        )
    bottom: list[rrb.Container | rrb.View] = []
    if plan.plots:
        plots = [time_series_view(p) for p in plan.plots]
        bottom.append(rrb.Grid(*plots, grid_columns=len(plots) if len(plots) <= 4 else math.ceil(len(plots) / 2)))
    bottom += [rrb.TextLogView(name=title, origin=origin) for title, origin in plan.text_logs]
    layout: rrb.Container | rrb.View = top
    if bottom:
        shares = [3.0] + [1.5] * (len(bottom) - 1) if plan.plots else [1.0] * len(bottom)
        row = rrb.Horizontal(*bottom, column_shares=shares) if len(bottom) > 1 else bottom[0]
        layout = rrb.Vertical(top, row, row_shares=[3, 2])
    return rrb.Blueprint(
        layout,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE, state="collapsed", play_state=opt.play_state or None),
        collapse_panels=False,
    )
