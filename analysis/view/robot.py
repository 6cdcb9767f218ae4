"""The robot in the 3D view: its footprint outline and heading under ``robot``, and where it starts.

With a TF path to the robot's base frame the outline is one static shape in that frame (the TF tree
moves it); without one it follows the poses the top-down view drew it at, in the fixed frame. The
first pose becomes ``summary.robot_start``, where the 3D camera starts (``blueprint``), and
``summary.robot_entity`` is what ``follow`` tracks.
"""

from __future__ import annotations

import math

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext
from navlog.analysis.view.tf import TfTree

Z = 0.03  # m above the base frame: over the occupancy grid
RADIUS = 0.02  # m: line half-width


def robot_strips(footprint: tuple[tuple[float, float], ...]) -> list[np.ndarray]:
    """The closed outline and a heading line from the centre to the front edge, at height Z."""
    fp = np.array(footprint + (footprint[0],), dtype=np.float64)
    outline = np.column_stack([fp, np.full(len(fp), Z)])
    front = float(fp[:, 0].max())
    heading = np.array([[0.0, 0.0, Z], [front, 0.0, Z]])
    return [outline.astype(np.float32), heading.astype(np.float32)]


def send_robot(
    ctx: ViewContext,
    tf: TfTree,
    base: str | None,
    poses: list[tuple[int, np.ndarray]],
    footprint: tuple[tuple[float, float], ...],
) -> None:
    """Draw the robot and set ``robot_start`` and ``robot_entity`` (nothing when its pose is unknown)."""
    rr, summary = ctx.rr, ctx.summary
    first = poses[0][1] if poses else (tf.to_fixed(base, None) if base is not None else None)
    if first is None:
        return
    yaw = math.atan2(first[1, 0], first[0, 0])
    summary.robot_start = (float(first[0, 3]), float(first[1, 3]), float(first[2, 3]), yaw)
    ent = ctx.entity("robot")
    strips = robot_strips(footprint)
    if base is not None:
        ctx.set_frame(ent, base)
        ctx.rec.log(ent, rr.LineStrips3D(strips, colors=[COLORS["footprint"]], radii=RADIUS), static=True)
    else:
        ctx.set_frame(ent, summary.fixed_frame)
        placed = [[s.astype(np.float64) @ m[:3, :3].T + m[:3, 3] for s in strips] for _, m in poses]
        ctx.rec.send_columns(
            ent,
            indexes=[ctx.time_column([t for t, _ in poses])],
            columns=rr.LineStrips3D.columns(strips=[s for pair in placed for s in pair]).partition([2] * len(placed)),
        )
        ctx.rec.log(ent, rr.LineStrips3D.from_fields(colors=[COLORS["footprint"]], radii=RADIUS), static=True)
    summary.robot_entity = "/robot"
