"""A replay output folder drawn beside its log: replay.mcap topics (under ``replay/``), the 2D map
(map.yaml), the 3D point map (map.pcd, coloured by height), the estimated trajectory (trajectory.tum) and a
SLAM's loop closures (pose_graph.json)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from navlog.analysis.view.context import ViewContext
from navlog.analysis.view.grids import Grids, crop_known
from navlog.analysis.view.trajectories import PoseRows, Trajectories
from navlog.errors import NavlogError
from navlog.replay.geometry import quat_from_yaw
from navlog.replay.io import LogReader, open_log

REPLAY_LOG = "replay.mcap"
REPLAY_PREFIX = "replay"


def add_replay_dir(
    out: Path,
    ctx: ViewContext,
    grids: Grids,
    trajectories: Trajectories,
    add_log: Callable[[LogReader, str], None],
) -> None:
    """Draw what a replay output folder holds; ``add_log(reader, prefix)`` reads its replay.mcap."""
    out = Path(out)
    if not out.is_dir():
        raise NavlogError(f"{out}: replay output folder does not exist")
    found = False
    mcap = out / REPLAY_LOG
    if mcap.is_file():
        with open_log(mcap) as r:
            add_log(r, REPLAY_PREFIX)
        found = True
    if (out / "map.yaml").is_file():
        found |= add_map_yaml(out / "map.yaml", ctx, grids)
    if (out / "map.pcd").is_file():
        add_pcd(out / "map.pcd", ctx)
        found = True
    if (out / "trajectory.tum").is_file():
        add_tum(out / "trajectory.tum", ctx, trajectories)
        found = True
    if (out / "pose_graph.json").is_file():
        add_pose_graph(out / "pose_graph.json", ctx, trajectories)
    if not found:
        raise NavlogError(f"{out}: no replay outputs found (expected replay.mcap, map.yaml, map.pcd or trajectory.tum)")


def replay_tf_children(out: Path) -> set[str]:
    """The child frames of the transforms a replay published (its replay.mcap's /tf: a SLAM's or AMCL's odom
    frame); none when it has no /tf or cannot be read (drawing the folder reports that)."""
    mcap = Path(out) / REPLAY_LOG
    if not mcap.is_file():
        return set()
    try:
        with open_log(mcap) as r:
            if "/tf" not in r.topics:
                return set()
            return {str(ts.child_frame_id) for env in r.messages(["/tf"]) for ts in env.msg.transforms}
    except (NavlogError, OSError):
        return set()


def add_map_yaml(path: Path, ctx: ViewContext, grids: Grids) -> bool:
    """The replayed map becomes the top-down view's grid; in 3D it is drawn as a static GridMap unless
    the replay.mcap's own ``/map`` (the same map as it grew) is drawn already."""
    from navlog.replay.io.map_server import load_map

    occ = load_map(path)
    ox, oy, yaw = occ.origin
    q = quat_from_yaw(yaw)
    cells, (cx, cy, _) = crop_known(occ.data, occ.resolution, (ox, oy, 0.0), q, ctx.opt.grid_margin_m)
    grids.static_map = ("replay/map", cells, occ.resolution, cx, cy)
    if grids.topics.get(f"{REPLAY_PREFIX}/map"):
        ctx.summary.drawn[str(path)] = f"grids/{REPLAY_PREFIX}/map"
        return True
    ent = ctx.entity("replay/map")
    ctx.set_frame(ent, occ.frame_id or "map")
    ctx.rec.log(ent, grids.gridmap(cells, occ.resolution, (cx, cy, 0.0), q), static=True)
    ctx.summary.drawn[str(path)] = ent
    return True


def height_colors(z: np.ndarray) -> np.ndarray:
    """RGB by height, blue (low) to red (high) between the 2nd and 98th percentiles."""
    if len(z) == 0:
        return np.zeros((0, 3), np.uint8)
    lo, hi = np.percentile(z, [2, 98])
    a = np.clip((z - lo) / max(hi - lo, 1e-6), 0, 1)
    return np.stack([255 * a, 80 + 100 * (1 - abs(a - 0.5) * 2), 255 * (1 - a)], axis=1).astype(np.uint8)


def add_pcd(path: Path, ctx: ViewContext) -> None:
    """The replayed point map as static points in the fixed frame (``map`` unless set)."""
    import open3d as o3d

    pcd = o3d.io.read_point_cloud(path)
    pts = np.asarray(pcd.points, dtype=np.float32)
    if len(pts) == 0:
        ctx.summary.warnings.append(f"{path}: empty point cloud")
    ent = ctx.entity("replay/map_pcd")
    ctx.set_frame(ent, ctx.opt.fixed_frame or "map")
    z = pts[:, 2] if len(pts) else np.zeros(0)
    ctx.rec.log(ent, ctx.rr.Points3D(pts, radii=ctx.rr.Radius.ui_points(2.0), colors=height_colors(z)), static=True)
    ctx.summary.points += len(pts)
    ctx.summary.drawn[str(path)] = ent


def add_tum(path: Path, ctx: ViewContext, trajectories: Trajectories) -> None:
    """The estimated trajectory, drawn with the odometry topics as ``replay/trajectory_tum``."""
    from navlog.analysis.metrics.trajectory import Trajectory

    traj = Trajectory.from_tum(path)
    o = PoseRows(frame=ctx.opt.fixed_frame or "map", child="")
    o.t = [int(v) for v in traj.times_ns]
    o.xyz = [tuple(r) for r in traj.positions]
    o.q = [tuple(r) for r in traj.quaternions]
    trajectories.topics["replay/trajectory_tum"] = o


def add_pose_graph(path: Path, ctx: ViewContext, trajectories: Trajectories) -> None:
    """A SLAM replay's loop closures (pose_graph.json's edges of kind ``loop``), each a segment between the two
    keyframes it joins, at their final poses in the graph's frame; a file that is not such a graph is a
    warning, and nothing of it is drawn."""
    try:
        graph = json.loads(path.read_text())
        nodes = {int(n["id"]): (float(n["x"]), float(n["y"])) for n in graph["nodes"]}
        pairs = [(nodes[int(e["source"])], nodes[int(e["target"])]) for e in graph["edges"] if e["kind"] == "loop"]
        frame = str(graph.get("frame_id") or ctx.opt.fixed_frame or "map")
    except (
        OSError,
        UnicodeDecodeError,
        ValueError,
        KeyError,
        TypeError,
        AttributeError,
        RecursionError,
        OverflowError,
    ) as exc:
        ctx.summary.warnings.append(
            f"{path}: not a pose graph navlog wrote ({type(exc).__name__}: {exc}); no loops drawn"
        )
        return
    segments = np.array([[[ax, ay, 0.0], [bx, by, 0.0]] for (ax, ay), (bx, by) in pairs], np.float64).reshape(-1, 2, 3)
    segments = segments[np.isfinite(segments).all(axis=(1, 2))].astype(np.float32)
    if len(segments):
        trajectories.loops["replay/pose_graph"] = (frame, segments)
