"""The metrics of one replay: trajectory (ATE, RPE), 2D map and 3D map, as a dict, a table and JSON.

``compute_metrics(log, replay_dir, ...)`` is what ``navlog metrics`` runs. It reads

- the ground-truth trajectory from the log (``/odom/ground_truth``, nav_msgs/Odometry, header stamps),
- ``OUT/trajectory.tum`` (the estimate), ``OUT/map.yaml`` (2D map) and ``OUT/map.pcd`` (3D map),
- the reference grid (``reference_map``) and the reference mesh (``reference_mesh``) when given,

and computes every metric whose inputs are there. A missing replay output or reference is not an
error: the metric is skipped and a note says which input it needs. Same inputs -> same JSON bytes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navlog.analysis.metrics import maps as map_metrics
from navlog.analysis.metrics import navigation as nav_metrics
from navlog.analysis.metrics import trajectory as tr
from navlog.analysis.tables import MISSING, grid, indented, render, table
from navlog.errors import NavlogError
from navlog.replay import messages as m
from navlog.replay.io import json_text, open_log
from navlog.replay.io.atomic import write_file

GT_TOPIC = "/odom/ground_truth"
EVENTS_TOPIC = "/navlog/events"
CMD_TOPIC = "/cmd_vel"
PCD_FRAMES = ("first-pose", "as-is", "aligned")
TRAJECTORY_FILE = "trajectory.tum"
MAP_FILE = "map.yaml"
PCD_FILE = "map.pcd"
# the 3D completeness's viewpoints lie at least this far apart along the path (one per pose of a 1e-9 m spacing
# filled memory); map offsets, view ranges and spacings are at most MAX_EXTENT_M (a planet's worth of metres)
MIN_VIEW_SPACING_M = 0.01
MAX_EXTENT_M = 1e7


@dataclass(frozen=True)
class MetricsOptions:
    """Parameters of ``compute_metrics``; validated on construction.

    ``pcd_frame``: how map.pcd is put into the world frame of the reference mesh. ``first-pose``
    (default) moves it by ``T_gt(t0) T_est(t0)^-1`` at the first matched pose -- the identity when the
    mapper already works in the world frame, and the right move when its frame starts at the robot's
    first pose, as FAST-LIO's does; ``aligned`` uses the ATE alignment; ``as-is`` takes it unchanged.
    """

    tau: float = 0.05
    taus_3d: tuple[float, ...] = map_metrics.DEFAULT_TAUS_3D
    max_diff_ns: int = tr.DEFAULT_MAX_DIFF_NS
    interpolate: bool = False  # ground truth interpolated at the estimate's stamps instead of nearest
    max_gap_ns: int = 100_000_000  # interpolation only between ground-truth poses this close
    align: str = "se3"
    rpe_delta: float = 1.0
    rpe_unit: str = "m"
    rpe_pairs_from: str = "reference"
    gt_topic: str = GT_TOPIC
    cmd_topic: str = CMD_TOPIC  # the commands the robot drove on (navigation: acceleration and jerk)
    # the replayed map's frame in the reference map's (x, y, yaw), e.g. a SLAM map against a saved one;
    # None: the same frame
    map_frame: tuple[float, float, float] | None = None
    pcd_frame: str = "first-pose"
    view_spacing_m: float = 0.5
    view_fov_deg: tuple[float, float] = (-15.0, 15.0)
    view_range_m: float = 30.0

    def __post_init__(self) -> None:
        def bad(name: str, value: Any, want: str) -> NavlogError:
            return NavlogError(f"metrics option {name} = {value!r}: {want}")

        if not (isinstance(self.tau, (int, float)) and math.isfinite(self.tau) and self.tau >= 0):
            raise bad("tau", self.tau, "must be a distance >= 0 in metres")
        if not self.taus_3d or any(not (math.isfinite(t) and t > 0) for t in self.taus_3d):
            raise bad("taus_3d", self.taus_3d, "must be one or more distances > 0 in metres")
        if not self.max_diff_ns >= 0:
            raise bad("max_diff", self.max_diff_ns, "must be >= 0")
        if not self.max_gap_ns > 0:
            raise bad("max_gap", self.max_gap_ns, "must be > 0")
        if self.map_frame is not None and not (
            len(self.map_frame) == 3
            and all(math.isfinite(float(v)) for v in self.map_frame)
            and max(abs(float(self.map_frame[0])), abs(float(self.map_frame[1]))) <= MAX_EXTENT_M
        ):
            raise bad(
                "map_frame",
                self.map_frame,
                f"must be three finite numbers: x, y (m, within {MAX_EXTENT_M:g}), yaw (rad)",
            )
        if self.align not in tr.ALIGN_MODES:
            raise bad("align", self.align, f"use one of {', '.join(tr.ALIGN_MODES)}")
        if self.rpe_unit not in tr.DELTA_UNITS:
            raise bad("rpe_unit", self.rpe_unit, f"use one of {', '.join(tr.DELTA_UNITS)}")
        if not (math.isfinite(self.rpe_delta) and self.rpe_delta > 0):
            raise bad("rpe_delta", self.rpe_delta, "must be > 0")
        if self.rpe_unit == "frames" and int(self.rpe_delta) != self.rpe_delta:
            raise bad("rpe_delta", self.rpe_delta, "must be a whole number of frames")
        lo, hi = self.view_fov_deg
        if not (-90.0 <= lo <= hi <= 90.0):
            raise bad("view_fov", self.view_fov_deg, "must be LOW HIGH elevations in degrees within -90..90")
        if not MIN_VIEW_SPACING_M <= self.view_spacing_m <= MAX_EXTENT_M:
            raise bad("view_spacing", self.view_spacing_m, f"must be {MIN_VIEW_SPACING_M} to {MAX_EXTENT_M:g} m")
        if not 0 < self.view_range_m <= MAX_EXTENT_M:
            raise bad("view_range", self.view_range_m, f"must be > 0 and at most {MAX_EXTENT_M:g} m")
        if self.rpe_pairs_from not in ("reference", "estimate"):
            raise bad("rpe_pairs_from", self.rpe_pairs_from, "use reference or estimate")
        if self.pcd_frame not in PCD_FRAMES:
            raise bad("pcd_frame", self.pcd_frame, f"use one of {', '.join(PCD_FRAMES)}")


# ---------------------------------------------------------------- inputs


def ground_truth_trajectory(reader, topic: str = GT_TOPIC) -> tuple[tr.Trajectory, dict[str, int]]:
    """Poses of a nav_msgs/Odometry topic by header stamp, sorted; repeated stamps keep the first.

    Returns the trajectory and counts of what was dropped or reordered."""
    info = reader.topics.get(topic)
    if info is None:
        have = ", ".join(f"{t.name} ({t.typename})" for t in sorted(reader.topics.values(), key=lambda t: t.name))
        raise NavlogError(f"{reader.path}: no topic {topic}; the log has {have or 'nothing'}")
    if info.typename != m.ODOMETRY:
        raise NavlogError(f"{reader.path}: topic {topic} is {info.typename}, expected {m.ODOMETRY}")
    times, rows = [], []
    for env in reader.messages([topic]):
        msg = env.msg
        if msg is None:
            continue
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        times.append(m.to_ns(msg.header.stamp))
        rows.append((p.x, p.y, p.z, q.x, q.y, q.z, q.w))
    if not times:
        raise NavlogError(f"{reader.path}: topic {topic} has no readable messages")
    t = np.asarray(times, dtype=np.int64)
    vals = np.asarray(rows, dtype=np.float64)
    order = np.argsort(t, kind="stable")
    out_of_order = int(np.count_nonzero(np.diff(t) < 0))
    t, vals = t[order], vals[order]
    first_of_stamp = np.concatenate([[True], np.diff(t) > 0])
    valid = np.all(np.isfinite(vals), axis=1) & (np.linalg.norm(vals[:, 3:], axis=1) > 1e-9)
    keep = first_of_stamp & valid
    counts = {
        "messages": len(times),
        "out_of_order": out_of_order,
        "repeated_stamps": int(np.count_nonzero(~first_of_stamp)),
        "invalid_poses": int(np.count_nonzero(~valid)),
    }
    return tr.Trajectory(t[keep], vals[keep, :3], vals[keep, 3:]), counts


def read_events(reader, topic: str = EVENTS_TOPIC) -> list[nav_metrics.Event]:
    """The log's navlog events as (time ns, kind, source, detail, value), by header stamp."""
    if topic not in reader.topics:
        return []
    out = []
    for env in reader.messages([topic]):
        e = env.msg
        if e is not None:
            out.append((m.to_ns(e.header.stamp), str(e.kind), str(e.source), str(e.detail), float(e.value)))
    return out


def read_commands(reader, topic: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(log times ns, linear x) of the velocity commands on ``topic`` (Twist or TwistStamped), or None."""
    if topic not in reader.topics:
        return None
    times, vx = [], []
    for env in reader.messages([topic]):
        if env.msg is not None:
            times.append(env.time_ns)
            vx.append(m.twist_values(env.msg)[0])
    return np.asarray(times, dtype=np.int64), np.asarray(vx, dtype=float)


def read_pcd_points(path: Path) -> np.ndarray:
    import open3d as o3d

    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        pcd = o3d.io.read_point_cloud(path)
    return np.asarray(pcd.points, dtype=np.float64)


def read_mesh(path: str | Path):
    import open3d as o3d

    p = Path(path)
    if not p.is_file():
        raise NavlogError(f"{p}: no such mesh file (--reference-mesh takes a .ply/.obj/.stl triangle mesh)")
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        mesh = o3d.io.read_triangle_mesh(p)
    if len(mesh.triangles) == 0:
        raise NavlogError(f"{p}: no triangles read; --reference-mesh needs a triangle mesh (.ply, .obj, .stl)")
    return mesh


# ---------------------------------------------------------------- the computation


def compute_metrics(
    log: str | Path,
    replay_dir: str | Path | None = None,
    *,
    reference_map: str | Path | None = None,
    reference_mesh: str | Path | None = None,
    options: MetricsOptions = MetricsOptions(),
    recover: bool = False,
) -> dict[str, Any]:
    """Every metric whose inputs exist, plus ``skipped`` notes for the others (see module doc).

    ``recover`` reads the complete chunks of a truncated MCAP log instead of refusing it.
    """
    from navlog.replay.io.map_server import load_map

    out_dir = Path(replay_dir) if replay_dir is not None else None
    if out_dir is not None and not out_dir.is_dir():
        raise NavlogError(f"{out_dir}: no such replay output folder (give the folder of `navlog replay ... -o OUT/`)")
    if reference_map is not None and not Path(reference_map).is_file():
        raise NavlogError(f"{reference_map}: no such map file (--reference-map takes a map_server YAML)")
    if reference_mesh is not None and not Path(reference_mesh).is_file():
        raise NavlogError(
            f"{reference_mesh}: no such mesh file (--reference-mesh takes a .ply/.obj/.stl triangle mesh)"
        )
    base = out_dir if out_dir is not None else Path("-no-replay-")  # no replay: no output file exists
    paths = {
        "trajectory": base / TRAJECTORY_FILE,
        "map": base / MAP_FILE,
        "pcd": base / PCD_FILE,
    }
    result: dict[str, Any] = {
        "inputs": {
            "log": str(log),
            "replay": str(out_dir) if out_dir is not None else None,
            **{k: (str(p) if p.is_file() else None) for k, p in paths.items()},
            "reference_map": str(reference_map) if reference_map else None,
            "reference_mesh": str(reference_mesh) if reference_mesh else None,
        },
        "parameters": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(options).items()},
    }
    skipped: list[str] = []

    # -- trajectory
    gt: tr.Trajectory | None = None
    est: tr.Trajectory | None = None
    with open_log(log, recover=recover) as reader:
        if options.gt_topic in reader.topics:
            gt, gt_counts = ground_truth_trajectory(reader, options.gt_topic)
        else:
            gt_counts = {}
            skipped.append(
                f"ATE, RPE, and the first-pose frame of map.pcd need the ground truth topic {options.gt_topic} "
                f"({m.ODOMETRY}) in the log; {reader.path} has none (choose another with --gt-topic)"
            )
        events = read_events(reader)
        commands = read_commands(reader, options.cmd_topic)
    ref_map = load_map(reference_map) if reference_map is not None else None
    nav = nav_metrics.navigation_metrics(events, gt, commands, ref_map)
    if nav is not None:
        result["navigation"] = nav
        if ref_map is None:
            skipped.append(
                "navigation clearance needs the true obstacles: --reference-map MAP.yaml "
                "(from `navlog world-map WORLD --margin 0 -o MAP.yaml`)"
            )
    if out_dir is None:
        skipped.append("ATE, RPE and the map metrics need a replay's outputs: --replay OUT/")
    elif paths["trajectory"].is_file():
        est = tr.Trajectory.from_tum(paths["trajectory"])
    else:
        skipped.append(f"ATE and RPE need the estimated trajectory {paths['trajectory']} (not found)")

    ate = None
    if gt is not None and est is not None:
        try:
            ref_a, est_a = _associate(gt, est, options)
            ate = tr.absolute_trajectory_error(ref_a, est_a, align_mode=options.align, max_diff_ns=None)  # type: ignore[arg-type]
        except tr.TrajectoryError as exc:
            skipped.append(f"ATE and RPE of {paths['trajectory']} against {options.gt_topic}: {exc}")
    if ate is not None and gt is not None and est is not None:
        section: dict[str, Any] = {
            "ground_truth_poses": len(gt),
            "ground_truth_read": gt_counts,
            "estimate_poses": len(est),
            "ate": ate.to_dict(),
        }
        try:
            rpe = tr.relative_pose_error(
                ref_a,
                est_a,
                delta=options.rpe_delta,
                unit=options.rpe_unit,  # type: ignore[arg-type]
                max_diff_ns=None,  # type: ignore[arg-type]
                align_mode="sim3" if options.align == "sim3" else "none",
                pairs_from=options.rpe_pairs_from,  # type: ignore[arg-type]
            )
            section["rpe"] = rpe.to_dict()
        except tr.TrajectoryError as exc:
            skipped.append(f"RPE: {exc}")
        result["trajectory"] = section

    # -- 2D map
    if out_dir is None:
        pass
    elif ref_map is None:
        skipped.append(
            "2D map precision/recall/F1, IoU, mean distances and coverage need a reference grid: "
            "--reference-map MAP.yaml (e.g. from `navlog world-map WORLD --margin 0 -o MAP.yaml`)"
        )
    elif not paths["map"].is_file():
        skipped.append(f"2D map metrics need the replayed map {paths['map']} (not found)")
    else:
        est_map = load_map(paths["map"])
        seed = tuple(gt.positions[0, :2]) if gt is not None and len(gt) else None
        gm = map_metrics.grid_metrics(est_map, ref_map, tau=options.tau, seed_xy=seed, est_to_ref=options.map_frame)
        result["map_2d"] = {
            **gm.to_dict(),
            "resolution_m": ref_map.resolution,
            "coverage_seed": "first ground-truth pose" if seed is not None else "largest free region",
        }

    # -- 3D map
    if out_dir is None:
        pass
    elif reference_mesh is None:
        skipped.append("3D map accuracy@tau needs the true surfaces: --reference-mesh MESH.ply")
    elif not paths["pcd"].is_file():
        skipped.append(f"3D map accuracy@tau needs the replayed point map {paths['pcd']} (not found)")
    else:
        mesh = read_mesh(reference_mesh)
        points = read_pcd_points(paths["pcd"])
        if len(points) == 0:
            skipped.append(f"3D map accuracy@tau: {paths['pcd']} holds no points (or is not a PCD file)")
        else:
            frame, transform = _pcd_transform(options.pcd_frame, gt, est, ate, options, skipped)
            pts = points @ transform[:3, :3].T + transform[:3, 3]
            result["map_3d"] = {
                **map_metrics.map_accuracy(pts, mesh, options.taus_3d),
                "frame": frame,
                "transform": [[float(v) for v in row] for row in transform[:3]],
            }
            if gt is not None and len(gt):
                views = gt.positions[viewpoint_indices(gt, options.view_spacing_m)]
                samples = map_metrics.visible_surface_samples(
                    mesh,
                    views,
                    directions=map_metrics.band_directions(options.view_fov_deg),
                    max_range=options.view_range_m,
                )
                result["map_3d"]["visible"] = {
                    **map_metrics.completeness(samples, pts, options.taus_3d),
                    "viewpoints": int(len(views)),
                }
            else:
                skipped.append(
                    f"3D completeness@tau needs the ground-truth path ({options.gt_topic}) for its viewpoints"
                )

    result["skipped"] = skipped
    if not any(k in result for k in ("trajectory", "map_2d", "map_3d", "navigation")):
        raise NavlogError("no metric could be computed: " + "; ".join(skipped))
    return result


def viewpoint_indices(traj: tr.Trajectory, spacing_m: float) -> np.ndarray:
    """Indices of the first pose and then one pose each ``spacing_m`` metres of path."""
    cells = np.floor(traj.path_lengths() / spacing_m).astype(np.int64)
    return np.flatnonzero(np.concatenate([[True], np.diff(cells) > 0]))


def _associate(gt: tr.Trajectory, est: tr.Trajectory, options: MetricsOptions) -> tuple[tr.Trajectory, tr.Trajectory]:
    if options.interpolate:
        return tr.associate_interpolated(gt, est, max_gap_ns=options.max_gap_ns)
    return tr.associate(gt, est, max_diff_ns=options.max_diff_ns)


def _pcd_transform(mode, gt, est, ate, options, skipped) -> tuple[str, np.ndarray]:
    if mode == "as-is":
        return "as-is", np.eye(4)
    if gt is None or est is None or ate is None:
        skipped.append(f"map.pcd taken as-is: the {mode} frame needs both trajectories")
        return "as-is", np.eye(4)
    if mode == "aligned":
        return "aligned", ate.alignment.matrix()
    ref_a, est_a = _associate(gt, est, options)
    t_world = ref_a.matrices()[0] @ np.linalg.inv(est_a.matrices()[0])
    return "first-pose", t_world


# ---------------------------------------------------------------- output


def to_json(metrics: dict[str, Any]) -> str:
    return json_text.dumps(metrics, indent=2) + "\n"


def write_json(metrics: dict[str, Any], path: str | Path) -> Path:
    return write_file(Path(path), to_json(metrics))


def _f(v: Any, unit: str = "", digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return MISSING
    if unit == "%":
        return f"{100.0 * v:.2f} %"
    return f"{v:.{digits}f}{' ' + unit if unit else ''}"


def _stats_row(label: str, s: dict, unit: str, note: str = "") -> tuple[str, ...]:
    return (label, _f(s["rmse"], unit), _f(s["mean"], unit), _f(s["median"], unit), _f(s["max"], unit), note)


def format_table(metrics: dict[str, Any]) -> str:
    """The metrics as text for people: one table per section, then the skipped notes."""
    replay = metrics["inputs"]["replay"]
    items: list[Any] = [
        f"Metrics of {replay} (log {metrics['inputs']['log']})" if replay else f"Metrics of {metrics['inputs']['log']}"
    ]
    n = metrics.get("navigation")
    if n:
        items.append(
            f"Navigation: {n['goals_succeeded']}/{n['goals_total']} goals reached, {n['collisions']} collision(s), "
            f"{n['recoveries']} recovery(ies), minimum clearance {_f(n.get('min_clearance_m'), 'm')}"
        )
        goal_rows = [
            (
                g["name"],
                g["status"] + (f" ({g['code']})" if g["code"] else ""),
                _f(g["time_s"], "s", 1),
                _f(g.get("path_length_m"), "m", 2),
                _f(g.get("min_clearance_m"), "m", 3),
                str(g["recoveries"]),
                str(g["collisions"]),
            )
            for g in n["goals"]
        ]
        items.append(
            indented(
                table(
                    ("goal", "result", "time", "path", "clearance", "recoveries", "collisions"),
                    goal_rows,
                    right=(2, 3, 4, 5, 6),
                )
            )
        )
        motion = [
            (label, _f(st["mean"], unit), _f(st["max"], unit), _f(st["rms"], unit))
            for label, key, unit in (
                ("speed (ground truth)", "speed_mps", "m/s"),
                ("|accel| of the command", "command_accel_mps2", "m/s2"),
                ("|jerk| of the command", "command_jerk_mps3", "m/s3"),
            )
            if (st := n.get(key))
        ]
        if motion:
            items.append(indented(table(("", "mean", "max", "rms"), motion, right=(1, 2, 3))))
    t = metrics.get("trajectory")
    if t:
        a = t["ate"]
        items.append(
            f"Trajectory: {t['estimate_poses']} estimated vs {t['ground_truth_poses']} ground-truth poses, "
            f"{a['pairs']} matched ({'interpolated' if metrics['parameters']['interpolate'] else 'nearest stamp'}), "
            f"{a['align']} alignment"
        )
        rows = [
            _stats_row("ATE translation", a["translation_m"], "m"),
            _stats_row("ATE rotation", a["rotation_deg"], "deg"),
        ]
        if "rpe" in t:
            r = t["rpe"]
            per = f"per {r['delta']:g} {r['unit']}, {r['pairs']} pairs"
            rows.append(_stats_row("RPE translation", r["translation_m"], "m", per))
            rows.append(_stats_row("RPE rotation", r["rotation_deg"], "deg"))
        items.append(indented(table(("", "rmse", "mean", "median", "max", ""), rows, right=(1, 2, 3, 4))))
    g = metrics.get("map_2d")
    if g:
        c = g["counts"]
        items.append(
            f"2D map: tau {g['tau_m']:g} m, {c['est_occupied']} occupied cells vs {c['ref_occupied']} in the reference"
        )
        rows = [
            ("precision", _f(g["precision"]), f"{c['matched_est_occupied']}/{c['est_occupied']} cells"),
            ("recall", _f(g["recall"]), f"{c['matched_ref_occupied']}/{c['ref_occupied']} cells"),
            ("F1", _f(g["f1"]), ""),
            (
                "recall (observable)",
                _f(g["recall_observable"]),
                f"{c['matched_ref_occupied_observable']}/{c['ref_occupied_observable']} surface cells facing "
                "reachable free space",
            ),
            ("F1 (observable)", _f(g["f1_observable"]), ""),
            ("IoU / IoU@tau", f"{_f(g['iou'])} / {_f(g['iou_tau'])}", ""),
            ("mean dist ref->map", _f(g["mean_dist_ref_to_est_m"], "m"), ""),
            ("mean dist map->ref", _f(g["mean_dist_est_to_ref_m"], "m"), ""),
            ("Chamfer / Hausdorff", f"{_f(g['chamfer_m'], 'm')} / {_f(g['hausdorff_m'], 'm')}", ""),
            ("free-space coverage", _f(g["coverage"], "%"), f"of {c['ref_free_reachable']} reachable free cells"),
        ]
        items.append(indented(grid(rows)))
        items += [f"  warning: {w}" for w in g.get("warnings", [])]
        if g["origin_residual_m"] > 1e-9:
            items.append(
                f"  note: origins differ by a fraction of a cell ({g['origin_residual_m']:.4f} m); "
                "compared on the nearest cells"
            )
    d = metrics.get("map_3d")
    if d:
        items.append(f"3D map: {d['points']} points, frame {d['frame']}")
        rows = [(f"accuracy@{tau} m", _f(share, "%"), "") for tau, share in d["accuracy"].items()]
        s = d["distance_m"]
        rows.append(
            (
                "distance to surface",
                "",
                f"mean {_f(s['mean'], 'm')}  median {_f(s['median'], 'm')}  max {_f(s['max'], 'm')}",
            )
        )
        v = d.get("visible")
        if v:
            rows.extend(
                (
                    f"completeness@{tau} m",
                    _f(share, "%"),
                    f"of {v['samples']} visible surface samples from {v['viewpoints']} viewpoints",
                )
                for tau, share in v["completeness"].items()
            )
        items.append(indented(grid(rows)))
    if metrics.get("skipped"):
        items.append("Skipped:")
        items.extend(f"  - {note}" for note in metrics["skipped"])
    return render(*items)
