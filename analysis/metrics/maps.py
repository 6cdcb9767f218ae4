"""Map quality against ground truth: 2D occupancy grids and 3D point maps.

2D (``grid_metrics``): an estimated ``OccupancyMap`` against a reference grid. The two are laid on
one canvas by their world origins (the origin offset is rounded to whole cells, the sub-cell
remainder is reported; origin yaw is ignored, as Nav2 does). A map of another resolution, or in
another frame (``est_to_ref``: the estimate's frame in the reference's, x, y, yaw — e.g. a SLAM
map against a saved map), is first resampled onto the reference's cell lattice (``resample_map``:
every cell takes the class of the estimate's cell under its centre, and every occupied cell of
the estimate stays occupied, so thin walls survive a coarser grid). Cells are
classified with map_server's thresholds (occupied > 0.65 -> value > 65, free < 0.196 -> value < 19.6,
anything else, -1 included, unknown). With ``d_X`` the Euclidean distance from a cell centre to the
nearest occupied cell centre of X (a distance transform):

- precision@tau: share of estimated occupied cells with ``d_ref <= tau``;
- recall@tau: share of reference occupied cells with ``d_est <= tau``; F1 their harmonic mean;
- recall (observable): the same over the reference cells that touch the reachable free space, the
  only ones a sensor inside it can see (a thick wall's inside never shows in a laser map);
- IoU: ``|E & R| / |E | R|`` of the occupied sets; IoU@tau the same of both sets dilated by tau;
- mean distance reference -> estimate (Santos et al.'s normalised error) and estimate -> reference
  (spurious cells), their mean (Chamfer) and the larger maximum (Hausdorff), in metres;
- coverage: share of the reference's free cells reachable from a seed (the largest free region when
  no seed is given) that the estimate knows as free.

A reference with a safety margin (obstacles inflated, as ``navlog world-map --margin`` draws them for
planning) has its walls in front of the mapped ones: when most mapped occupied cells lie at least two
cells (and more than tau) inside the reference's obstacles, ``warnings`` says so (``reference_margin_m``).

3D: accuracy@tau (share of map points within tau of a triangle mesh, exact point-to-mesh distance
with Open3D's ``RaycastingScene``), completeness@tau (share of caller-given visible surface samples
within tau of the map), Chamfer and Hausdorff distances between point sets (scipy ``cKDTree``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from navlog.analysis.metrics.trajectory import ErrorStats
from navlog.errors import NavlogError
from navlog.replay.occupancy_map import OccupancyMap

#: map_server's thresholds as navlog saves maps (see navlog.replay.io.map_server.SAVE_FREE_THRESH).
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
DEFAULT_TAUS_3D = (0.02, 0.05)
MAX_CANVAS_CELLS = 200_000_000


class MapMetricError(NavlogError):
    """Two maps cannot be compared."""


# ---------------------------------------------------------------- 2D: classification and alignment


def classify(data: np.ndarray, *, occupied_thresh: float = OCCUPIED_THRESH, free_thresh: float = FREE_THRESH):
    """(occupied, free) boolean masks of int8 occupancy values (-1 unknown, 0..100)."""
    v = np.asarray(data).astype(np.int16)
    occupied = v > occupied_thresh * 100.0
    free = (v >= 0) & (v < free_thresh * 100.0)
    return occupied, free & ~occupied


@dataclass(frozen=True)
class GridFrame:
    """Where the estimate sits on the reference grid: cell offsets and the sub-cell remainder."""

    offset_cells: tuple[int, int]  # (rows, cols) of the estimate's cell (0, 0) on the reference grid
    residual_m: float  # largest |origin offset - rounded offset| over x and y
    canvas_shape: tuple[int, int]
    ref_slice: tuple[slice, slice]
    est_slice: tuple[slice, slice]


def grid_frame(ref: OccupancyMap, est: OccupancyMap, *, rel_tol: float = 1e-6) -> GridFrame:
    """The common canvas of two grids of equal resolution, aligned on world coordinates."""
    res = ref.resolution
    if abs(est.resolution - res) > rel_tol * res:
        raise MapMetricError(
            f"map resolution {est.resolution:g} m differs from the reference's {res:g} m; "
            f"make the reference at the map's resolution (navlog world-map WORLD --resolution {est.resolution:g})"
        )
    fx = (est.origin[0] - ref.origin[0]) / res
    fy = (est.origin[1] - ref.origin[1]) / res
    dc, dr = int(round(fx)), int(round(fy))
    residual = max(abs(fx - dc), abs(fy - dr)) * res
    r0, c0 = min(0, dr), min(0, dc)
    r1, c1 = max(ref.height, dr + est.height), max(ref.width, dc + est.width)
    shape = (r1 - r0, c1 - c0)
    if shape[0] * shape[1] > MAX_CANVAS_CELLS:
        raise MapMetricError(
            f"the map (origin {est.origin[:2]}) and the reference (origin {ref.origin[:2]}) are "
            f"{shape[1] * res:.0f} x {shape[0] * res:.0f} m apart together; are they in the same frame?"
        )
    ref_sl = (slice(-r0, -r0 + ref.height), slice(-c0, -c0 + ref.width))
    est_sl = (slice(dr - r0, dr - r0 + est.height), slice(dc - c0, dc - c0 + est.width))
    return GridFrame((dr, dc), float(residual), shape, ref_sl, est_sl)


def resample_map(
    est: OccupancyMap, ref: OccupancyMap, *, est_to_ref: Sequence[float] = (0.0, 0.0, 0.0)
) -> OccupancyMap:
    """``est`` on ``ref``'s cell lattice (its resolution, cells aligned with its cells, yaw 0).

    ``est_to_ref`` = (x, y, yaw) places the estimate's frame in the reference's. Each output cell
    takes the value of the estimate's cell under its centre (unknown outside the estimate); each
    occupied estimate cell, sampled at sub-cells no larger than half an output cell, marks the
    output cells it covers occupied. Origin yaws are ignored, as in ``grid_frame``.
    """
    res = ref.resolution
    tx, ty, yaw = (float(v) for v in est_to_ref)
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    w, h = est.width * est.resolution, est.height * est.resolution
    corners = np.array([[0, 0], [w, 0], [0, h], [w, h]]) + np.asarray(est.origin[:2])
    world = corners @ rot.T + (tx, ty)
    lo = np.floor((world.min(axis=0) - ref.origin[:2]) / res)  # in reference cells
    hi = np.ceil((world.max(axis=0) - ref.origin[:2]) / res)
    nx, ny = (hi - lo).astype(int)
    if nx * ny > MAX_CANVAS_CELLS:
        raise MapMetricError(f"resampling the map onto {res:g} m cells needs {nx} x {ny} cells; is est_to_ref right?")
    origin = np.asarray(ref.origin[:2]) + lo * res
    # every output cell centre, back into the estimate's cells
    gx, gy = np.meshgrid(origin[0] + (np.arange(nx) + 0.5) * res, origin[1] + (np.arange(ny) + 0.5) * res)
    local = (np.stack([gx.ravel() - tx, gy.ravel() - ty], axis=1) @ rot) - est.origin[:2]
    ij = np.floor(local / est.resolution).astype(np.int64)
    inside = (ij[:, 0] >= 0) & (ij[:, 0] < est.width) & (ij[:, 1] >= 0) & (ij[:, 1] < est.height)
    out = np.full(nx * ny, -1, dtype=np.int8)
    out[inside] = est.data[ij[inside, 1], ij[inside, 0]]
    out = out.reshape(ny, nx)
    # occupied cells forward, at sub-cells of at most half an output cell: no wall is lost
    occ_r, occ_c = np.nonzero(classify(est.data)[0])
    k = max(1, int(np.ceil(2.0 * est.resolution / res)))
    sub = (np.arange(k) + 0.5) / k
    su, sv = np.meshgrid(sub, sub)
    px = (occ_c[:, None] + su.ravel()[None, :]) * est.resolution + est.origin[0]
    py = (occ_r[:, None] + sv.ravel()[None, :]) * est.resolution + est.origin[1]
    pts = np.stack([px.ravel(), py.ravel()], axis=1) @ rot.T + (tx, ty)
    cells = np.floor((pts - origin) / res).astype(np.int64)
    ok = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
    out[cells[ok, 1], cells[ok, 0]] = 100
    return OccupancyMap(out, res, (float(origin[0]), float(origin[1]), 0.0), frame_id=ref.frame_id)


def _on_canvas(frame: GridFrame, sl: tuple[slice, slice], mask: np.ndarray) -> np.ndarray:
    out = np.zeros(frame.canvas_shape, dtype=bool)
    out[sl] = mask
    return out


def _distance_cells(mask: np.ndarray) -> np.ndarray:
    """Distance in cells from every cell centre to the nearest True cell (inf when there is none)."""
    if not mask.any():
        return np.full(mask.shape, np.inf)
    return ndimage.distance_transform_edt(~mask)


def _f1(precision: float, recall: float) -> float:
    if not (np.isfinite(precision) and np.isfinite(recall)):
        return float("nan")
    return 2.0 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0


def _ratio(num: int, den: int) -> float:
    return float(num) / float(den) if den else float("nan")


# ---------------------------------------------------------------- 2D: metrics


@dataclass(frozen=True)
class GridMetrics:
    tau_m: float
    precision: float
    recall: float
    f1: float
    iou: float
    iou_tau: float
    mean_dist_ref_to_est_m: float
    mean_dist_est_to_ref_m: float
    chamfer_m: float
    hausdorff_m: float
    coverage: float
    recall_observable: float = float("nan")
    f1_observable: float = float("nan")
    counts: dict[str, int] = field(default_factory=dict)
    offset_cells: tuple[int, int] = (0, 0)
    origin_residual_m: float = 0.0
    resampled_from: str = ""  # what the estimate was resampled from ('' when compared as it was)
    warnings: tuple[str, ...] = ()  # what makes the figures misleading (a reference with a safety margin)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k in (
            "tau_m",
            "precision",
            "recall",
            "f1",
            "iou",
            "iou_tau",
            "mean_dist_ref_to_est_m",
            "mean_dist_est_to_ref_m",
            "chamfer_m",
            "hausdorff_m",
            "coverage",
            "recall_observable",
            "f1_observable",
        ):
            v = float(getattr(self, k))
            out[k] = v if np.isfinite(v) else None
        out["counts"] = dict(self.counts)
        out["offset_cells"] = [int(v) for v in self.offset_cells]
        out["origin_residual_m"] = float(self.origin_residual_m)
        if self.resampled_from:
            out["resampled_from"] = self.resampled_from
        if self.warnings:
            out["warnings"] = list(self.warnings)
        return out


def reachable_free(free: np.ndarray, seed_rc: tuple[int, int] | None = None) -> np.ndarray:
    """The 4-connected region of ``free`` containing the free cell nearest to ``seed_rc`` (row, col),
    or the largest region when no seed is given."""
    labels, n = ndimage.label(free)
    if n == 0:
        return np.zeros_like(free)
    if seed_rc is None:
        sizes = np.bincount(labels.ravel())[1:]
        return labels == (int(np.argmax(sizes)) + 1)
    r = int(np.clip(seed_rc[0], 0, free.shape[0] - 1))
    c = int(np.clip(seed_rc[1], 0, free.shape[1] - 1))
    if not free[r, c]:
        _, (ir, ic) = ndimage.distance_transform_edt(~free, return_indices=True)
        r, c = int(ir[r, c]), int(ic[r, c])
    return labels == labels[r, c]


def grid_metrics(
    est: OccupancyMap,
    ref: OccupancyMap,
    *,
    tau: float = 0.05,
    seed_xy: Sequence[float] | None = None,
    occupied_thresh: float = OCCUPIED_THRESH,
    free_thresh: float = FREE_THRESH,
    est_to_ref: Sequence[float] | None = None,
) -> GridMetrics:
    """Compare an estimated map with a reference grid; see the module docstring for definitions.

    ``tau`` in metres (0 = exact cells). ``seed_xy``: a world point in the reachable free space
    (e.g. the robot's start) for coverage. ``est_to_ref``: the estimate's frame in the reference's
    (x, y, yaw); given, or when the resolutions differ, the estimate is resampled (``resample_map``)."""
    if not tau >= 0:
        raise MapMetricError(f"tolerance tau must be >= 0 m, got {tau}")
    resampled = est_to_ref is not None or abs(est.resolution - ref.resolution) > 1e-6 * ref.resolution
    source = ""
    if resampled:
        source = f"{est.resolution:g} m cells, est_to_ref {tuple(float(v) for v in (est_to_ref or (0, 0, 0)))}"
        est = resample_map(est, ref, est_to_ref=est_to_ref if est_to_ref is not None else (0.0, 0.0, 0.0))
    frame = grid_frame(ref, est)
    res = ref.resolution
    r_occ, r_free = classify(ref.data, occupied_thresh=occupied_thresh, free_thresh=free_thresh)
    e_occ, e_free = classify(est.data, occupied_thresh=occupied_thresh, free_thresh=free_thresh)
    R = _on_canvas(frame, frame.ref_slice, r_occ)
    E = _on_canvas(frame, frame.est_slice, e_occ)
    RF = _on_canvas(frame, frame.ref_slice, r_free)
    EF = _on_canvas(frame, frame.est_slice, e_free)

    d_ref = _distance_cells(R)  # cells to the nearest reference occupied cell
    d_est = _distance_cells(E)
    tau_cells = tau / res + 1e-6
    n_e, n_r = int(E.sum()), int(R.sum())
    tp_e = int(np.count_nonzero(d_ref[E] <= tau_cells))
    tp_r = int(np.count_nonzero(d_est[R] <= tau_cells))
    precision, recall = _ratio(tp_e, n_e), _ratio(tp_r, n_r)
    f1 = _f1(precision, recall)

    union = int(np.count_nonzero(E | R))
    iou = _ratio(int(np.count_nonzero(E & R)), union)
    dil_e, dil_r = d_est <= tau_cells, d_ref <= tau_cells
    iou_tau = _ratio(int(np.count_nonzero(dil_e & dil_r)), int(np.count_nonzero(dil_e | dil_r)))

    to_est = d_est[R] * res
    to_ref = d_ref[E] * res
    mean_re = float(np.mean(to_est)) if n_r and n_e else float("nan")
    mean_er = float(np.mean(to_ref)) if n_r and n_e else float("nan")
    hausdorff = float(max(np.max(to_est), np.max(to_ref))) if n_r and n_e else float("nan")

    seed_rc = None
    if seed_xy is not None:
        mx, my = ref.world_to_cell(float(seed_xy[0]), float(seed_xy[1]))
        seed_rc = (my + frame.ref_slice[0].start, mx + frame.ref_slice[1].start)
    reach = reachable_free(RF, seed_rc)
    n_reach = int(reach.sum())
    coverage = _ratio(int(np.count_nonzero(reach & EF)), n_reach)
    # the reference surfaces a sensor in the reachable free space can see: occupied cells touching it
    # (a wall's inside and the far side of the room's walls are never observable)
    surface = R & ndimage.binary_dilation(reach, structure=np.ones((3, 3), dtype=bool))
    n_s = int(surface.sum())
    tp_s = int(np.count_nonzero(d_est[surface] <= tau_cells))
    recall_obs = _ratio(tp_s, n_s)

    warnings = _margin_warning(E, R, res, tau)
    counts = {
        "ref_occupied": n_r,
        "est_occupied": n_e,
        "matched_est_occupied": tp_e,
        "matched_ref_occupied": tp_r,
        "ref_free_reachable": n_reach,
        "est_free": int(EF.sum()),
        "est_free_on_ref_occupied": int(np.count_nonzero(EF & R)),
        "ref_occupied_observable": n_s,
        "matched_ref_occupied_observable": tp_s,
    }
    return GridMetrics(
        tau_m=float(tau),
        precision=precision,
        recall=recall,
        f1=float(f1),
        iou=iou,
        iou_tau=iou_tau,
        mean_dist_ref_to_est_m=mean_re,
        mean_dist_est_to_ref_m=mean_er,
        chamfer_m=(mean_re + mean_er) / 2.0,
        hausdorff_m=hausdorff,
        coverage=coverage,
        recall_observable=recall_obs,
        f1_observable=float(_f1(precision, recall_obs)),
        counts=counts,
        offset_cells=frame.offset_cells,
        origin_residual_m=frame.residual_m,
        resampled_from=source,
        warnings=warnings,
    )


MARGIN_MIN_CELLS = 2.0  # a reference's walls this far (and more than tau) in front of the mapped ones: a margin
MARGIN_INSIDE_SHARE = 0.5  # ... for at least this share of the mapped occupied cells


def reference_margin_m(est_occupied: np.ndarray, ref_occupied: np.ndarray, resolution: float) -> float | None:
    """How far inside the reference's obstacles the estimate's occupied cells lie (the median, in m, of
    their distance to the reference's nearest non-occupied cell less the one cell of an edge), when most
    of them lie inside; else None.

    A laser maps the surfaces of obstacles, which a reference without margin has on its edge (a depth of
    up to a cell); a reference with a safety margin (obstacles inflated by ``m``, as ``navlog world-map
    --margin m`` draws them for planning) has them ``m`` inside, so its occupied edge lies ``m`` in front
    of every mapped wall, and recall and IoU count that band as missed walls."""
    inside = est_occupied & ref_occupied
    if not est_occupied.any() or inside.sum() < MARGIN_INSIDE_SHARE * est_occupied.sum():
        return None
    depth = ndimage.distance_transform_edt(ref_occupied)[inside]  # cells to the nearest non-occupied cell
    return (float(np.median(depth)) - 1.0) * resolution  # an edge cell is one cell from the free space


def _margin_warning(
    est_occupied: np.ndarray, ref_occupied: np.ndarray, resolution: float, tau: float
) -> tuple[str, ...]:
    margin = reference_margin_m(est_occupied, ref_occupied, resolution)
    if margin is None or margin < max(MARGIN_MIN_CELLS * resolution, tau + resolution):
        return ()
    return (
        f"the mapped walls lie {margin:.2f} m (median) inside the reference's obstacles: the reference looks "
        "inflated by a safety margin, so recall, IoU and the distances count that band as missed walls; "
        "compare against a reference without margin (`navlog world-map WORLD --margin 0 -o MAP.yaml`)",
    )


# ---------------------------------------------------------------- 3D


def _points(points, what: str = "points") -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.size == 0:
        return np.zeros((0, 3))
    if p.ndim != 2 or p.shape[1] != 3:
        raise MapMetricError(f"{what} must be an (N, 3) array, got shape {p.shape}")
    finite = np.all(np.isfinite(p), axis=1)
    return p[finite]


def _raycasting_scene(mesh):
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    if isinstance(mesh, o3d.geometry.TriangleMesh):
        vertices, triangles = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    elif isinstance(mesh, o3d.t.geometry.TriangleMesh):
        vertices, triangles = mesh.vertex.positions.numpy(), mesh.triangle.indices.numpy()
    else:
        vertices, triangles = mesh
    vertices = np.asarray(vertices, dtype=np.float32).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.uint32).reshape(-1, 3)
    if len(triangles) == 0:
        raise MapMetricError("reference mesh has no triangles")
    if triangles.max() >= len(vertices):
        raise MapMetricError(f"reference mesh: triangle index {int(triangles.max())} >= {len(vertices)} vertices")
    scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))
    return scene


def point_to_mesh_distances(points, mesh) -> np.ndarray:
    """Unsigned distance (m) from each point to the nearest mesh surface.

    ``mesh``: an Open3D legacy or tensor TriangleMesh, or a (vertices (V, 3), triangles (T, 3)) pair.
    Distances are computed in float32 by Open3D (about 1e-6 m at room scale)."""
    import open3d as o3d

    p = _points(points)
    if len(p) == 0:
        return np.zeros(0)
    scene = _raycasting_scene(mesh)
    d = scene.compute_distance(o3d.core.Tensor(p.astype(np.float32)))  # type: ignore[call-overload]
    return d.numpy().astype(np.float64)


def share_within(distances, taus: Iterable[float]) -> dict[str, float | None]:
    """{"0.05": share of distances <= 0.05, ...} (keys are the taus as text)."""
    d = np.asarray(distances, dtype=np.float64)
    out: dict[str, float | None] = {}
    for tau in taus:
        out[_tau_key(tau)] = float(np.count_nonzero(d <= tau + 1e-9)) / len(d) if len(d) else None
    return out


def _tau_key(tau: float) -> str:
    return f"{float(tau):g}"


def map_accuracy(points, mesh, taus: Iterable[float] = DEFAULT_TAUS_3D) -> dict[str, Any]:
    """Accuracy@tau of map points against a mesh, and statistics of their distances."""
    d = point_to_mesh_distances(points, mesh)
    return {"points": int(len(d)), "accuracy": share_within(d, taus), "distance_m": ErrorStats.of(d).to_dict()}


def nearest_distances(query, points) -> np.ndarray:
    """Distance from each query point to its nearest neighbour in ``points`` (cKDTree)."""
    q, p = _points(query, "query points"), _points(points)
    if len(q) == 0:
        return np.zeros(0)
    if len(p) == 0:
        return np.full(len(q), np.inf)
    d, _ = cKDTree(p).query(q, k=1)
    return np.asarray(d, dtype=np.float64)


def band_directions(
    elevation_deg: tuple[float, float] = (-15.0, 15.0), n_elevation: int = 16, n_azimuth: int = 720
) -> np.ndarray:
    """Unit ray directions of a spinning LiDAR: ``n_elevation`` rings evenly over the elevation band
    (degrees), ``n_azimuth`` columns over 360 degrees. Shape (n_elevation * n_azimuth, 3)."""
    lo, hi = (float(v) for v in elevation_deg)
    if not (-90.0 <= lo <= hi <= 90.0) or n_elevation < 1 or n_azimuth < 1:
        raise MapMetricError(f"view band: elevation {elevation_deg} deg must lie in -90..90 with low <= high")
    el = np.radians(np.linspace(lo, hi, n_elevation) if n_elevation > 1 else np.array([(lo + hi) / 2]))
    az = np.arange(n_azimuth) * (2 * np.pi / n_azimuth)
    e, a = np.meshgrid(el, az, indexing="ij")
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)


def visible_surface_samples(
    mesh,
    viewpoints,
    *,
    directions: np.ndarray | None = None,
    max_range: float = 30.0,
    voxel: float = 0.02,
    batch_rays: int = 1 << 20,
) -> np.ndarray:
    """Points of the mesh surface that rays from the viewpoints hit first (within ``max_range``),
    thinned to one per ``voxel`` cube (the first in sorted voxel order): the truly visible surface
    that completeness@tau is measured against. ``directions`` default: ``band_directions()``."""
    import open3d as o3d

    views = _points(viewpoints, "viewpoints")
    dirs = band_directions() if directions is None else np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    if len(views) == 0 or len(dirs) == 0:
        return np.zeros((0, 3))
    scene = _raycasting_scene(mesh)
    per_batch = max(1, batch_rays // len(dirs))
    hits = []
    for start in range(0, len(views), per_batch):
        origins = views[start : start + per_batch]
        rays = np.concatenate([np.repeat(origins, len(dirs), axis=0), np.tile(dirs, (len(origins), 1))], axis=1).astype(
            np.float32
        )
        hit = scene.cast_rays(o3d.core.Tensor(rays))  # type: ignore[call-overload]
        t = hit["t_hit"].numpy().astype(np.float64)
        ok = np.isfinite(t) & (t <= max_range)
        hits.append(rays[ok, :3].astype(np.float64) + t[ok, None] * rays[ok, 3:].astype(np.float64))
    pts = np.concatenate(hits) if hits else np.zeros((0, 3))
    if len(pts) == 0 or voxel <= 0:
        return pts
    _, first = np.unique(np.floor(pts / voxel).astype(np.int64), axis=0, return_index=True)
    return pts[first]


def completeness(surface_samples, map_points, taus: Iterable[float] = DEFAULT_TAUS_3D) -> dict[str, Any]:
    """Completeness@tau: share of (visible) surface samples within tau of a map point."""
    d = nearest_distances(surface_samples, map_points)
    return {"samples": int(len(d)), "completeness": share_within(d, taus)}


def chamfer_hausdorff(points_a, points_b) -> dict[str, float | None]:
    """Mean nearest-neighbour distance a -> b and b -> a, their mean (Chamfer) and the largest
    nearest-neighbour distance either way (Hausdorff), in metres."""
    ab = nearest_distances(points_a, points_b)
    ba = nearest_distances(points_b, points_a)
    if len(ab) == 0 or len(ba) == 0:
        return {"mean_a_to_b_m": None, "mean_b_to_a_m": None, "chamfer_m": None, "hausdorff_m": None}
    mab, mba = float(np.mean(ab)), float(np.mean(ba))
    return {
        "mean_a_to_b_m": mab,
        "mean_b_to_a_m": mba,
        "chamfer_m": (mab + mba) / 2.0,
        "hausdorff_m": float(max(np.max(ab), np.max(ba))),
    }
