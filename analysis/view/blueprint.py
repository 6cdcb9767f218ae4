"""The default Rerun blueprint: the 3D view beside the top-down view, time-series tabs and text logs."""

from __future__ import annotations

from navlog.analysis.view.context import TIMELINE
from navlog.analysis.view.options import ViewSummary


def make_blueprint(summary: ViewSummary):
    """The default layout: 3D view | (2D top-down, time series tabs, events); only views with content."""
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
    right: list[rrb.View | rrb.Container] = []
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
