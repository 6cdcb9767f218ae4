"""2D SLAM on the classic public datasets (Intel, ACES, Seattle, FHW): global and local accuracy.

Each CARMEN dataset in external-data/carmen/ of the external data folder (``--shared DIR``; default
``$NAVLOG_SHARED_DIR``, else ``shared`` beside the repository) is replayed in this process with
``--pipeline mapping --set pose_source=slam`` (default parameters, ``lidar_mapper=off``) and scored
against ``NAME.reference.tum`` (the dataset's corrected trajectory at the scan stamps), side by side
with the wheel odometry alone (the bag's odom -> base_footprint at the same stamps):

- **ATE**: RMSE of the positions after the best SE(2) alignment (Umeyama, no scale);
- **RE 1 m / 5 m**: relative error in the style of Kuemmerle et al. (2009): for every scan i, the
  first later scan j with at least 1 m (5 m) of reference travel since i; the error is the norm of
  the difference between the estimated and the reference translation of j in i's frame; the mean;
- **walls**: the share of the occupied cells of a map drawn from the estimate (aligned onto the
  reference) that lie within 0.10 m of an occupied cell of the map drawn from the same scans at
  the reference poses (0.05 m cells, navlog's grid rules);
- **overlap**: a figure that needs no reference: for every third scan, the median distance of its points
  (within 20 m) to the nearest point of the scans at least 30 scans away in the log (the other passes
  through the same place), the mean over the scans that have 20 such neighbours within 0.5 m, in cm;
  also printed for the reference trajectory itself (a map whose passes agree scores low), and for both over the
  tenth of those scans where the SLAM and the reference lie farthest apart after alignment (whose passes agree
  better where the two differ most);
- **loops**: loop-closure edges in pose_graph.json (each checked below the dataset against the reference's
  relative pose of its two keyframes, counted by what found it, ``closed_by``; under each more than 0.5 m off,
  its scan matched against the keyframes around its source drawn at the SLAM's and at the reference's poses:
  whether the scans prefer the edge's place or the reference's), and (**global**) how many of them the global search
  (``loop_search_global``) closed, over its searches; **wall s** / **x real**: the replay's wall time
  and the log's duration over it (with the load average: the machine is shared); **x (CPU)**: the
  log's duration over the CPU time of the replay.

Below each dataset, **own RE 1 m**: each of the reference, the SLAM and the odometry's own RMS error over 1 m
of travel, from the three compared with each other (``navlog.analysis.metrics.own_relative_errors``, the
three-cornered hat: their errors taken as independent; ``-`` where that does not hold and a mean square comes
out negative). The reference is itself an estimate: against it, a SLAM without error would score the reference's
own error. With ``--reference-noise SIGMA`` the same with
seeded noise added to the reference's positions, a check of the method on the data: the reference's own
figure should grow to sqrt(own^2 + 4 SIGMA^2) (two positions per move, two axes), the others' stay. The last
line counts the keyframes the wider searches placed where the odometry jumped (pose_graph.json
``odometry_jumps``), and of them the turns the odometry missed (more than the sequential search's fan), and the
steps back the odometry measured forward (``reversals_missed``: wheels that do not report driving backwards) and
the times the SLAM read the odometry backwards (``reversals_inferred``, ``infer_reversing``).

With ``--maps DIR``, ``DIR/NAME-maps.png``: the walls of the map drawn from the reference and of the one drawn
from the SLAM side by side, in the 16 m square centred where the SLAM is farthest from the reference.

With ``--floor`` a third row, **matched on the reference**: every scan matched alone (navlog's
correlative matcher, default parameters) against the previous ``scan_buffer_size`` scans placed at
their reference poses, from its own reference pose: how far the scans themselves place a pose from
the reference when the map is the reference's own. Its RE 1 m is the floor of this metric for the
matcher: the reference is itself a SLAM result, not ground truth. And a fourth, **SLAM on reference
odometry**: the same SLAM (``Slam2D``, the replay's parameters, in this process) given the reference poses
as its odometry, error-free: how far the scans carry the path from the reference when nothing else
does.

With ``--odometry-error KIND=VALUE`` (repeatable) a row per error, **KIND VALUE**: the same SLAM (in this
process, as the fourth row) given the bag's own odometry at the scan stamps degraded
(``tests/replay/mapping/planar_logs.py``: ``turn=0.05`` every turn 5 % too large, ``length=0.1`` every
step 10 % too long, ``drift=0.02`` 0.02 rad of heading gained per metre, ``noise=0.05`` seeded Gaussian
noise of 5 % on every step): how the defaults fare on a robot whose wheels are worse than the dataset's.

With ``--ensemble`` the rows of ``ENSEMBLE``'s six errors (every turn 5 % too large and too small, every step
5 % too long, 0.02 rad of heading gained and lost per metre, 5 % noise), and at the end the mean ATE of the SLAM
over its own odometry and those six, per dataset and over all of them (28 runs for the four datasets): a
figure that moves less than any single run's with which closures happen to pass.

With ``--driven-back`` a row **driven back**: the same SLAM (in this process) on the log driven back over its
path (``planar_logs.driven_back``: its scans and odometry poses in reverse order, a robot reversing with
its forward-facing laser), scored against the reference reversed.

Nothing is asserted; the issue's targets are ATE <= 0.10 m, RE 1 m <= 0.03 m and never above
odometry, walls >= 0.9, >= 10x real time.

    .venv/bin/python benchmarks/bench_slam_datasets.py [NAME ...] [--shared DIR] [--set KEY=VALUE ...] [--floor]
        [--odometry-error KIND=VALUE ...] [--ensemble] [--driven-back] [--reference-noise SIGMA]
        [--maps DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from navlog.analysis.metrics import (
    align_planar,
    own_relative_errors,
    planar_ate,
    planar_in_frame,
    planar_relative_error,
)
from navlog.replay.geometry import planar_matrix, se2_compose
from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams
from navlog.replay.mapping.slam2d import LaserScan2D, ScanMatcher, SearchWindow, SlamParams
from navlog.replay.mapping.slam2d.scan_matcher import transform_points
from navlog.replay.mapping.slam2d.slam import surface_points
from navlog.replay.session import pipeline_params, run_replay

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data
from tests.replay.mapping.planar_logs import (
    ODOMETRY_ERRORS,
    degraded_odometry,
    driven_back,
    planar_tum,
    read_bag,
    slam_on_odometry,
)
from tests.shared_data import default_shared_dir

DATASETS = ["intel", "aces", "seattle", "fhw"]
# --ensemble: the odometry errors whose runs, with the dataset's own odometry, give the mean ATE
ENSEMBLE = [("turn", 0.05), ("turn", -0.05), ("length", 0.05), ("drift", 0.02), ("drift", -0.02), ("noise", 0.05)]
WALL_REACH = 0.10  # m


def load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def draw(poses: np.ndarray, stamps: np.ndarray, scans: dict[int, tuple]) -> OccupancyGrid2D:
    grid = OccupancyGrid2D(OccupancyParams(resolution=0.05))
    for t, (x, y, yaw) in zip(stamps.tolist(), poses.tolist(), strict=True):
        a, r, lo, hi = scans[t]
        grid.insert_scan(planar_matrix(x, y, yaw), a, r, lo, hi)
    return grid


def occupied_xy(grid: OccupancyGrid2D) -> np.ndarray:
    iy, ix = np.nonzero(grid.logodds > 0.6)  # p > 0.65: navlog's occupied threshold
    return grid.origin + (np.column_stack([ix, iy]) + 0.5) * grid.res


def wall_agreement(est_grid: OccupancyGrid2D, ref_grid: OccupancyGrid2D) -> float:
    ref_occ = ref_grid.logodds > 0.6
    dist = ndimage.distance_transform_edt(~ref_occ) * ref_grid.res
    pts = occupied_xy(est_grid)
    if len(pts) == 0:
        return float("nan")
    cells = np.floor((pts - ref_grid.origin) / ref_grid.res).astype(int)
    ny, nx = ref_occ.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
    near = np.zeros(len(pts), dtype=bool)
    near[inside] = dist[cells[inside, 1], cells[inside, 0]] <= WALL_REACH
    return float(near.mean())


def overlap(medians: dict[int, float]) -> float:
    """The reference-free agreement of the passes (see the module docstring), in cm, from ``scan_overlaps``."""
    return 100 * float(np.mean(list(medians.values()))) if medians else float("nan")


def scan_overlaps(poses: np.ndarray, stamps: np.ndarray, scans: dict[int, tuple]) -> dict[int, float]:
    """``overlap``'s scans: for every third scan with 20 such neighbours, its index -> the median distance (m)."""
    points = [LaserScan2D(*scans[t], np.eye(4)).points(20.0) for t in stamps.tolist()]
    placed = np.concatenate([transform_points(p, q) for p, q in zip(poses, points, strict=True)])
    owner = np.repeat(np.arange(len(points)), [len(q) for q in points])
    tree = cKDTree(placed)
    medians = {}
    for i in range(0, len(points), 3):
        d, j = tree.query(transform_points(poses[i], points[i]), k=60, distance_upper_bound=0.5)
        far = np.zeros(d.shape, dtype=bool)
        hit = j < len(placed)
        far[hit] = np.abs(owner[j[hit]] - i) >= 30
        nearest = np.where(far, d, np.inf).min(axis=1)
        nearest = nearest[np.isfinite(nearest)]
        if len(nearest) >= 20:
            medians[i] = float(np.median(nearest))
    return medians


def where_they_disagree(
    est: np.ndarray, ref: np.ndarray, mine: dict[int, float], theirs: dict[int, float]
) -> tuple[float, float, int]:
    """``overlap`` of ``est`` and of the reference (cm; ``mine`` and ``theirs``: their ``scan_overlaps``) over the
    scans both score where the two lie farthest apart after alignment (the tenth of them): which of the two has
    its passes agree better where they differ most; and how many scans that is."""
    both = np.array(sorted(set(mine) & set(theirs)), dtype=np.int64)
    if not len(both):
        return float("nan"), float("nan"), 0
    apart = np.linalg.norm(align_planar(est, ref)[both, :2] - ref[both, :2], axis=1)
    worst = both[np.argsort(apart)[-max(1, len(both) // 10) :]]
    return (
        100 * float(np.mean([mine[i] for i in worst])),
        100 * float(np.mean([theirs[i] for i in worst])),
        len(worst),
    )


MAP_WINDOW = 16.0  # m: the side of the square ``--maps`` shows


def plot_maps(path: Path, name: str, est: np.ndarray, ref: np.ndarray, est_grid, ref_grid) -> None:
    """``path`` (PNG): the walls of the map drawn from the reference and of ``est_grid``, the one drawn from
    ``est`` aligned onto it (``estimate_grid``), side by side, in the ``MAP_WINDOW`` square centred where
    ``est`` is farthest from the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    aligned = align_planar(est, ref)
    worst = int(np.argmax(np.linalg.norm(aligned[:, :2] - ref[:, :2], axis=1)))
    lo = ref[worst, :2] - MAP_WINDOW / 2
    fig, axes = plt.subplots(1, 2, figsize=(12, 6.4), sharex=True, sharey=True)
    for ax, grid, colour, title in (
        (axes[0], ref_grid, "tab:red", "drawn from the reference"),
        (axes[1], est_grid, "tab:blue", "drawn from the SLAM"),
    ):
        xy = occupied_xy(grid)
        inside = np.all((xy >= lo) & (xy <= lo + MAP_WINDOW), axis=1)
        ax.scatter(xy[inside, 0], xy[inside, 1], s=1.5, c=colour, linewidths=0, marker="s")
        ax.set_title(f"{name}: walls {title}")
        ax.set_aspect("equal")
        ax.grid(True, linewidth=0.3)
        ax.set_xlabel("x (m)")
    axes[0].set_ylabel("y (m)")
    axes[0].set_xlim(lo[0], lo[0] + MAP_WINDOW)
    axes[0].set_ylim(lo[1], lo[1] + MAP_WINDOW)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def estimate_grid(est: np.ndarray, ref: np.ndarray, stamps: np.ndarray, scans) -> OccupancyGrid2D:
    """The map drawn from the scans at ``est``'s poses aligned onto the reference."""
    return draw(align_planar(est, ref), stamps, scans)


def score(
    est: np.ndarray, ref: np.ndarray, stamps: np.ndarray, scans, ref_grid, est_grid=None, est_overlaps=None
) -> dict[str, float]:
    """The figures of the module docstring; ``est_grid``: ``estimate_grid``'s map, and ``est_overlaps``: ``est``'s
    ``scan_overlaps``, each computed when not given."""
    if est_grid is None:
        est_grid = estimate_grid(est, ref, stamps, scans)
    if est_overlaps is None:
        est_overlaps = scan_overlaps(est, stamps, scans)
    return {
        "ate": planar_ate(est, ref),
        "re1": planar_relative_error(est, ref, 1.0),
        "re5": planar_relative_error(est, ref, 5.0),
        "walls": wall_agreement(est_grid, ref_grid),
        "overlap": overlap(est_overlaps),
    }


def matched_on_reference(ref: np.ndarray, stamps: np.ndarray, scans: dict[int, tuple]) -> np.ndarray:
    """Every scan's pose matched alone against the previous ``scan_buffer_size`` scans at their reference poses
    (the first scan and unmatched ones keep their reference pose)."""
    p = SlamParams()
    matcher = ScanMatcher(p.correlation_search_space_resolution, p.correlation_search_space_smear_deviation)
    window = SearchWindow(p.correlation_search_space_dimension, p.coarse_search_angle_offset, p.coarse_angle_resolution)
    points, surfaces = [], []
    for t in stamps.tolist():
        a, r, lo, hi = scans[t]
        pts = LaserScan2D(a, r, lo, hi, np.eye(4)).points(p.max_laser_range)
        points.append(pts)
        surfaces.append(
            surface_points(
                pts, p.correlation_search_space_resolution / 2, 1.5 * p.correlation_search_space_smear_deviation
            )
        )
    out = ref.copy()
    for i in range(1, len(ref)):
        lo = max(0, i - p.scan_buffer_size)
        reference = np.concatenate([transform_points(ref[j], surfaces[j]) for j in range(lo, i)])
        match = matcher.match(reference, points[i], ref[i], window, p.link_match_minimum_response_fine)
        if match is not None:
            out[i] = match.pose
    return out


def loop_errors(graph: dict, ref_at: dict[int, np.ndarray]) -> tuple[np.ndarray, list[dict]]:
    """The loop edges of a pose_graph.json whose two keyframes' stamps the reference has, and per edge the distance
    between the position of its target in its source's frame it measured and the reference's (m)."""
    stamp = {n["id"]: n["stamp_ns"] for n in graph["nodes"]}
    loops = [e for e in graph["edges"] if e["kind"] == "loop"]
    loops = [e for e in loops if stamp[e["source"]] in ref_at and stamp[e["target"]] in ref_at]
    if not loops:
        return np.zeros(0), loops
    source = np.array([ref_at[stamp[e["source"]]] for e in loops])
    target = np.array([ref_at[stamp[e["target"]]][:2] for e in loops])
    measured = np.array([(e["x"], e["y"]) for e in loops])
    return np.linalg.norm(measured - planar_in_frame(source, target), axis=1), loops


def where_the_scans_put_it(
    graph: dict, edge: dict, scans: dict[int, tuple], ref_at: dict[int, np.ndarray], side: int = 10
) -> list[str]:
    """For a loop edge: the target keyframe's scan matched in a 3 m square against the scans of the ``side``
    keyframes either side of its source, drawn at the SLAM's poses and at the reference's. Per map: the scan's
    response at that trajectory's own pose, its best response and where (along x and y of the source's frame),
    and its response at the other one's relative pose (the edge's on the reference's map, the reference's on
    the SLAM's): do the scans decide between the two?"""
    p = SlamParams()
    matcher = ScanMatcher(p.correlation_search_space_resolution, p.correlation_search_space_smear_deviation)
    window = SearchWindow(3.0, 0.2, p.coarse_angle_resolution / 2)
    stamp = {n["id"]: n["stamp_ns"] for n in graph["nodes"]}
    source, target = edge["source"], edge["target"]
    near = [k for k in range(source - side, source + side + 1) if k in stamp and stamp[k] in ref_at]

    def points(k: int) -> np.ndarray:
        return LaserScan2D(*scans[stamp[k]], np.eye(4)).points(p.max_laser_range)

    slam_at = {n["id"]: np.array([n["x"], n["y"], n["yaw"]]) for n in graph["nodes"]}
    ref_of = {k: np.asarray(ref_at[stamp[k]]) for k in near + [target]}
    reference_rel = planar_in_frame(ref_of[source][None], ref_of[target][None, :2])[0]
    reference_rel = (*reference_rel, ref_of[target][2] - ref_of[source][2])
    edge_rel = (edge["x"], edge["y"], edge["yaw"])
    scan = points(target)
    lines = []
    for label, at, other, other_label in (
        ("SLAM", slam_at, reference_rel, "the reference's"),
        ("reference", ref_of, edge_rel, "the edge's"),
    ):
        reference = np.concatenate([transform_points(at[k], points(k)) for k in near])
        if not len(reference) or not len(scan):
            continue
        grid = matcher.grid(reference, window)  # whole: read at poses that may lie outside the window too
        best = matcher.match_on(grid, scan, at[target], window, 0.0)
        placed = np.array(se2_compose(at[source], other))
        found = ""
        if best is not None:
            bx, by = planar_in_frame(at[source][None], best.pose[None, :2])[0]
            found = f"best {best.response:.3f} at ({bx:.2f}, {by:.2f})"
        lines.append(
            f"on the {label}'s map: {grid.response(at[target], scan):.3f} at its own pose, {found},"
            f" {grid.response(placed, scan):.3f} at {other_label} relative pose"
        )
    return lines


def odometry_error(text: str) -> tuple[str, float]:
    """``KIND=VALUE`` of ``--odometry-error``."""
    kind, _, value = text.partition("=")
    if kind not in ODOMETRY_ERRORS:
        raise argparse.ArgumentTypeError(f"{text!r}: KIND is one of {', '.join(ODOMETRY_ERRORS)}")
    try:
        number = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: VALUE is a number, e.g. {kind}=0.05") from None
    if not (math.isfinite(number) and -0.5 < number < 0.5):
        raise argparse.ArgumentTypeError(f"{text!r}: VALUE lies between -0.5 and 0.5")
    return kind, number


def evaluate(
    name: str,
    carmen: Path,
    work: Path,
    sets: list[str],
    floor: bool = False,
    errors: list[tuple[str, float]] = (),
    back: bool = False,
    reference_noise: float = 0.0,
    maps: Path | None = None,
) -> list[float]:
    """Print the dataset's rows; return the ATE of the SLAM on the bag's odometry and on each of ``errors``."""
    bag = carmen / name
    ref_t, ref = planar_tum(carmen / f"{name}.reference.tum")
    scans, odom_at = read_bag(bag)
    ref_grid = draw(ref, ref_t, scans)
    out = work / name
    before = load()
    start, cpu = time.perf_counter(), time.process_time()
    run_replay(
        bag,
        "mapping",
        out,
        overrides=["pose_source=slam", "lidar_mapper=off", *sets],
        progress=False,
        force=True,
    )
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    est_t, est = planar_tum(out / "trajectory.tum")
    where = {t: i for i, t in enumerate(est_t.tolist())}
    keep = np.array([t in where for t in ref_t.tolist()])
    ts = ref_t[keep]
    slam = est[[where[t] for t in ts.tolist()]]
    odom = np.array([odom_at[t] for t in ts.tolist()])
    graph = json.loads((out / "pose_graph.json").read_text())
    loops = sum(e["kind"] == "loop" for e in graph["edges"])
    ref_at = dict(zip(ref_t.tolist(), ref, strict=True))
    closure_errors, closures = loop_errors(graph, ref_at)
    found = f"{graph['counts']['loops_global']}/{graph['counts']['global_searches']}"
    duration = (ref_t[-1] - ref_t[0]) / 1e9
    travel = float(np.sum(np.linalg.norm(np.diff(ref[:, :2], axis=0), axis=1)))
    rows = [("slam", slam), ("odometry", odom)]
    slam_params = pipeline_params("mapping", overrides=sets).slam  # the replay's, --set included
    if floor:
        rows.append(("on ref.", matched_on_reference(ref[keep], ts, scans)))
        rows.append(("ref. odom", slam_on_odometry(ref[keep], ts, scans, slam_params)))
    averaged = {"slam"}  # the rows whose ATE evaluate returns
    for kind, value in errors:
        label = f"{kind} {value:g}"
        averaged.add(label)
        rows.append((label, slam_on_odometry(degraded_odometry(odom, kind, value), ts, scans, slam_params)))
    scored = [(source, poses, ref[keep], ts, scans) for source, poses in rows]
    if back:
        back_ts, back_scans, back_odom = driven_back(ts, scans, odom)
        back_poses = slam_on_odometry(back_odom, back_ts, back_scans, slam_params)
        scored.append(("driven back", back_poses, ref[keep][::-1], back_ts, back_scans))
    slam_grid = estimate_grid(slam, ref[keep], ts, scans)  # scored below, and drawn by --maps
    slam_overlaps, ref_overlaps = scan_overlaps(slam, ts, scans), scan_overlaps(ref[keep], ts, scans)  # (each once)
    ates = []
    for source, est_poses, truth, stamps, logged in scored:
        computed = (slam_grid, slam_overlaps) if source == "slam" else ()
        s = score(est_poses, truth, stamps, logged, ref_grid, *computed)
        if source in averaged:
            ates.append(s["ate"])
        extra = (
            f"{loops:>6} {found:>7} {wall:>7.1f} {duration / wall:>8.1f}x {duration / cpu:>8.1f}x"
            if source == "slam"
            else f"{'-':>6} {'-':>7} {'-':>7} {'-':>9} {'-':>9}"
        )
        print(
            f"{name if source == 'slam' else '':<8} {source:<11} {s['ate']:>7.3f} {s['re1']:>7.3f} {s['re5']:>7.3f}"
            f" {s['walls']:>6.2f} {s['overlap']:>7.2f} {extra}",
            flush=True,
        )
    if maps is not None:
        maps.mkdir(parents=True, exist_ok=True)
        plot_maps(maps / f"{name}-maps.png", name, slam, ref[keep], slam_grid, ref_grid)
    reference = overlap(ref_overlaps)
    print(f"{'':<8} {'reference':<11} {'-':>7} {'-':>7} {'-':>7} {'-':>6} {reference:>7.2f}", flush=True)
    for sigma in (0.0, *([reference_noise] if reference_noise else [])):
        noisy = ref[keep].copy()
        noisy[:, :2] += np.random.default_rng(0).normal(0.0, sigma, (len(noisy), 2))
        own = own_relative_errors(noisy, slam, odom, 1.0, along=ref[keep])  # the same moves with or without noise
        shown = ["-" if math.isnan(v) else f"{v:.3f}" for v in own]
        print(
            f"{'':<8} own RE 1 m (RMS; reference{f' + {sigma:g} m noise' if sigma else ''}, SLAM and odometry "
            f"against each other): reference {shown[0]}, SLAM {shown[1]}, odometry {shown[2]}",
            flush=True,
        )
    mine, theirs, count = where_they_disagree(slam, ref[keep], slam_overlaps, ref_overlaps)
    print(
        f"{'':<8} overlap where the SLAM and the reference lie farthest apart ({count} scans, the tenth of those"
        f" scored): SLAM {mine:.2f} cm, reference {theirs:.2f} cm",
        flush=True,
    )
    if len(closure_errors):
        print(
            f"{'':<8} loop closures against the reference's relative pose of their keyframes: median"
            f" {np.median(closure_errors):.3f} m, largest {closure_errors.max():.3f} m, {int(np.sum(closure_errors > 0.5))}"
            " more than 0.5 m off",
            flush=True,
        )
        closed_by = np.array([e.get("closed_by", "") for e in closures])
        by = ", ".join(
            f"{kind} {int(np.sum(closed_by == kind))} (largest {closure_errors[closed_by == kind].max():.3f} m)"
            for kind in ("scan", "buffer", "global")
            if (closed_by == kind).any()
        )
        print(f"{'':<8} found by the scan's own match, the running buffer's, the global search: {by}", flush=True)
        for e, error in zip(closures, closure_errors.tolist(), strict=True):
            if error > 0.5:
                print(
                    f"{'':<8} keyframes {e['source']} -> {e['target']}: {error:.3f} m off, found by"
                    f" {e.get('closed_by') or '-'}, response {e['response']:.3f}, at ({e['x']:.2f}, {e['y']:.2f});"
                    " its scan against the keyframes around the source:",
                    flush=True,
                )
                for line in where_the_scans_put_it(graph, e, scans, ref_at):
                    print(f"{'':<12} {line}", flush=True)
    jumps = graph["odometry_jumps"]
    turned = sum(abs(j["turn"]) > slam_params.coarse_search_angle_offset for j in jumps)
    reversals = len(graph.get("reversals_missed", []))
    backwards = sum(r["read"] == "backwards" for r in graph.get("reversals_inferred", []))
    print(
        f"{'':<8} ({len(ts)}/{len(ref_t)} scans placed, {travel:.0f} m, odometry jumps {len(jumps)} ({turned} turns),"
        f" steps back the odometry measured forward {reversals}, read backwards {backwards},"
        f" load {before} -> {load()})",
        flush=True,
    )
    return ates


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", default=DATASETS, help="datasets in external-data/carmen/")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    ap.add_argument(
        "--floor",
        action="store_true",
        help="also score scans matched on the reference's own map, and the SLAM given the reference as odometry",
    )
    ap.add_argument(
        "--set", action="append", default=[], help="a SLAM parameter override, e.g. slam.do_loop_closing=false"
    )
    ap.add_argument(
        "--odometry-error",
        action="append",
        default=[],
        type=odometry_error,
        metavar="KIND=VALUE",
        help="also score the SLAM on the bag's odometry degraded: "
        + "; ".join(f"{k}: {v}" for k, v in ODOMETRY_ERRORS.items()),
    )
    ap.add_argument(
        "--ensemble",
        action="store_true",
        help="also score the SLAM on six degraded odometries ("
        + ", ".join(f"{k}={v:g}" for k, v in ENSEMBLE)
        + ") and print the mean ATE over them and the bag's own, per dataset and over all",
    )
    ap.add_argument(
        "--driven-back", action="store_true", help="also score the SLAM on the log driven back over its path"
    )
    ap.add_argument(
        "--reference-noise",
        type=float,
        default=0.0,
        metavar="SIGMA",
        help="also measure the own RE 1 m with seeded noise of SIGMA m (each axis) added to the reference's "
        "positions: its own error should grow to sqrt(own^2 + 4 SIGMA^2), the others' stay",
    )
    ap.add_argument(
        "--maps",
        type=Path,
        metavar="DIR",
        help="write NAME-maps.png there: the walls drawn from the reference and from the SLAM, side by side, "
        f"in the {MAP_WINDOW:g} m square around the SLAM's largest error",
    )
    args = ap.parse_args()
    carmen = args.shared / "external-data" / "carmen"
    print(f"machine: {os.cpu_count()} cores, load average {load()}")
    print(
        f"{'dataset':<8} {'source':<11} {'ATE m':>7} {'RE1 m':>7} {'RE5 m':>7} {'walls':>6} {'overlap':>7} {'loops':>6} {'global':>7} {'wall s':>7} {'x real':>9} {'x (CPU)':>9}"
    )
    errors = [*args.odometry_error, *(e for e in ENSEMBLE if e not in args.odometry_error and args.ensemble)]
    means = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.names:
            ates = evaluate(
                name,
                carmen,
                Path(tmp),
                args.set,
                args.floor,
                errors,
                args.driven_back,
                args.reference_noise,
                args.maps,
            )
            means[name] = ates
    if args.ensemble:
        runs = [a for ates in means.values() for a in ates]
        print(
            f"mean ATE of the SLAM over the bag's own odometry and the degraded ones ({len(runs)} runs): "
            + ", ".join(f"{name} {np.mean(ates):.4f}" for name, ates in means.items())
            + f"; all {np.mean(runs):.4f} m"
        )


if __name__ == "__main__":
    main()
