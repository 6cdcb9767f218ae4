"""Map metrics on hand-made grids and a box mesh with known answers."""

from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest

from navlog.analysis.metrics import maps as mm
from navlog.replay.occupancy_map import OccupancyMap

RES = 0.05


def _outline(
    n: int = 20, lo: int = 5, hi: int = 14, col_shift: int = 0, outside: int = 0, inside: int = 0
) -> np.ndarray:
    """An n x n grid: a square outline (rows/cols lo..hi, columns shifted) of 100, other cells
    ``outside`` / ``inside`` the square."""
    g = np.full((n, n), outside, dtype=np.int8)
    g[lo + 1 : hi, lo + 1 + col_shift : hi + col_shift] = inside
    g[[lo, hi], lo + col_shift : hi + 1 + col_shift] = 100
    g[lo : hi + 1, [lo + col_shift, hi + col_shift]] = 100
    return g


def _brute_force(est: np.ndarray, ref: np.ndarray, tau_cells: float):
    """Independent precision / recall / dilated IoU by comparing every pair of cells."""
    e = np.argwhere(est > 65).astype(float)
    r = np.argwhere(ref > 65).astype(float)
    d = np.linalg.norm(e[:, None, :] - r[None, :, :], axis=2)
    precision = np.mean(d.min(axis=1) <= tau_cells + 1e-9)
    recall = np.mean(d.min(axis=0) <= tau_cells + 1e-9)
    cells = np.argwhere(np.ones(ref.shape, bool)).astype(float)
    near_e = np.linalg.norm(cells[:, None] - e[None], axis=2).min(axis=1) <= tau_cells + 1e-9
    near_r = np.linalg.norm(cells[:, None] - r[None], axis=2).min(axis=1) <= tau_cells + 1e-9
    iou_tau = np.sum(near_e & near_r) / np.sum(near_e | near_r)
    return precision, recall, iou_tau, d.min(axis=0).mean(), d.min(axis=1).mean()


def test_classification_uses_map_server_thresholds():
    values = np.array([[-1, 0, 19, 20, 50, 65, 66, 100]], dtype=np.int8)
    occ, free = mm.classify(values)
    assert occ.tolist() == [[False, False, False, False, False, False, True, True]]
    assert free.tolist() == [[False, True, True, False, False, False, False, False]]


def test_identical_maps_are_perfect():
    ref = OccupancyMap(_outline(), RES)
    g = mm.grid_metrics(ref, ref, tau=0.0)
    assert (g.precision, g.recall, g.f1, g.iou, g.iou_tau) == (1.0, 1.0, 1.0, 1.0, 1.0)
    assert g.chamfer_m == 0.0 and g.hausdorff_m == 0.0
    assert g.counts["ref_occupied"] == 36


def test_outline_shifted_by_one_cell():
    ref = OccupancyMap(_outline(), RES)
    est = OccupancyMap(_outline(col_shift=1), RES)
    exact = mm.grid_metrics(est, ref, tau=0.0)
    # 36 cells each; the top and bottom rows share 9 cells each, the sides share none
    assert exact.counts["matched_est_occupied"] == 18
    assert exact.precision == pytest.approx(0.5)
    assert exact.recall == pytest.approx(0.5)
    assert exact.f1 == pytest.approx(0.5)
    assert exact.iou == pytest.approx(18 / 54)
    # half of the cells of each map are one cell (5 cm) from the other map
    assert exact.mean_dist_ref_to_est_m == pytest.approx(0.025)
    assert exact.mean_dist_est_to_ref_m == pytest.approx(0.025)
    assert exact.hausdorff_m == pytest.approx(0.05)
    one_cell = mm.grid_metrics(est, ref, tau=RES)
    assert (one_cell.precision, one_cell.recall, one_cell.f1) == (1.0, 1.0, 1.0)
    assert one_cell.iou == pytest.approx(exact.iou)  # the plain IoU does not depend on tau


@pytest.mark.parametrize("tau_cells", [0.0, 1.0, 1.5])
def test_against_brute_force(tau_cells):
    rng = np.random.default_rng(3)
    ref = np.where(rng.random((24, 24)) < 0.1, 100, 0).astype(np.int8)
    est = np.where(rng.random((24, 24)) < 0.1, 100, 0).astype(np.int8)
    g = mm.grid_metrics(OccupancyMap(est, RES), OccupancyMap(ref, RES), tau=tau_cells * RES)
    p, r, iou_tau, ne_ref, ne_est = _brute_force(est, ref, tau_cells)
    assert g.precision == pytest.approx(p)
    assert g.recall == pytest.approx(r)
    assert g.iou_tau == pytest.approx(iou_tau)
    assert g.mean_dist_ref_to_est_m == pytest.approx(ne_ref * RES)
    assert g.mean_dist_est_to_ref_m == pytest.approx(ne_est * RES)


def test_origins_and_sizes_are_aligned_on_world_coordinates():
    ref = OccupancyMap(_outline(), RES, origin=(-0.5, -0.5, 0.0))
    # the same square in a smaller grid (rows/cols 3.. of the reference) with another origin
    crop = _outline()[3:17, 2:18]
    est = OccupancyMap(crop, RES, origin=(-0.5 + 2 * RES, -0.5 + 3 * RES, 0.0))
    g = mm.grid_metrics(est, ref, tau=0.0)
    assert g.offset_cells == (3, 2)
    assert (g.precision, g.recall, g.iou) == (1.0, 1.0, 1.0)
    # moving the origin one cell along +x is the one-cell shift of the square
    moved = OccupancyMap(_outline(), RES, origin=(-0.5 + RES, -0.5, 0.0))
    s = mm.grid_metrics(moved, ref, tau=0.0)
    assert s.offset_cells == (0, 1)
    assert s.precision == pytest.approx(0.5) and s.iou == pytest.approx(18 / 54)
    # a sub-cell origin difference is rounded and reported
    nudged = OccupancyMap(_outline(), RES, origin=(-0.5 + 0.02, -0.5, 0.0))
    n = mm.grid_metrics(nudged, ref, tau=0.0)
    assert n.offset_cells == (0, 0) and n.origin_residual_m == pytest.approx(0.02)
    assert n.precision == 1.0


def test_estimate_outside_the_reference_counts_as_false_positive():
    ref = OccupancyMap(_outline(), RES)
    est_data = np.zeros((4, 4), dtype=np.int8)
    est_data[0, 0] = 100
    est = OccupancyMap(est_data, RES, origin=(5.0, 5.0, 0.0))  # 100 cells away
    g = mm.grid_metrics(est, ref, tau=RES)
    assert g.precision == 0.0 and g.recall == 0.0 and g.f1 == 0.0


def test_coverage_of_reachable_free_space():
    ref = OccupancyMap(_outline(outside=0, inside=0), RES)  # free inside (64 cells) and outside (300)
    est_data = np.full((20, 20), -1, dtype=np.int8)
    est_data[6:14, 6:10] = 0  # the left half of the inside
    est_data[5, 7] = 0  # a wall cell seen as free
    est = OccupancyMap(est_data, RES)
    inside = mm.grid_metrics(est, ref, seed_xy=(0.5, 0.5))  # cell (10, 10): inside the square
    assert inside.counts["ref_free_reachable"] == 64
    assert inside.coverage == pytest.approx(32 / 64)
    assert inside.counts["est_free_on_ref_occupied"] == 1
    largest = mm.grid_metrics(est, ref)  # no seed: the outside region is larger
    assert largest.counts["ref_free_reachable"] == 400 - 100
    assert largest.coverage == 0.0
    corner_inside = mm.grid_metrics(est, ref, seed_xy=(0.31, 0.31))  # cell (6, 6), inside
    assert corner_inside.counts["ref_free_reachable"] == 64


def test_empty_estimate_gives_undefined_precision():
    ref = OccupancyMap(_outline(), RES)
    est = OccupancyMap(np.zeros((20, 20), dtype=np.int8), RES)
    g = mm.grid_metrics(est, ref).to_dict()
    assert g["precision"] is None and g["recall"] == 0.0 and g["f1"] is None
    assert g["counts"]["est_occupied"] == 0


def test_different_resolutions_are_refused_by_the_canvas_and_resampled_by_the_metrics():
    ref = OccupancyMap(_outline(), RES)
    est = OccupancyMap(_outline(), 0.1)
    with pytest.raises(mm.MapMetricError, match="--resolution 0.1"):
        mm.grid_frame(ref, est)
    assert mm.grid_metrics(est, ref).resampled_from.startswith("0.1 m cells")


def _room(res: float, est_to_ref=(0.0, 0.0, 0.0), half: float = 2.0, size: float = 6.0) -> OccupancyMap:
    """A square room (walls 0.1 m thick at |x|, |y| = ``half``, free inside) drawn on a grid of ``res``
    whose frame sits at ``est_to_ref`` in the room's frame; unknown outside the walls."""
    n = int(round(size / res))
    origin = -size / 2
    u, v = np.meshgrid(origin + (np.arange(n) + 0.5) * res, origin + (np.arange(n) + 0.5) * res)
    tx, ty, yaw = est_to_ref
    x = tx + np.cos(yaw) * u - np.sin(yaw) * v
    y = ty + np.sin(yaw) * u + np.cos(yaw) * v
    m = np.maximum(np.abs(x), np.abs(y))
    data = np.full((n, n), -1, dtype=np.int8)
    data[m < half] = 0
    data[(m >= half) & (m < half + 0.1)] = 100
    return OccupancyMap(data, res, (origin, origin, 0.0))


@pytest.mark.parametrize("res", [0.05, 0.1, 0.03])
def test_a_map_of_another_resolution_is_resampled(res):
    ref = _room(0.05)
    g = mm.grid_metrics(_room(res), ref, tau=0.05)
    assert g.f1 >= 0.97 and g.coverage >= 0.97, g
    assert (g.resampled_from != "") == (res != 0.05)


def test_a_map_in_a_rotated_and_offset_frame_is_compared_in_the_reference_frame():
    # a SLAM-like map whose frame is the room's turned 30 degrees and moved (0.4, -0.3) m
    pose = (0.4, -0.3, np.radians(30.0))
    est, ref = _room(0.05, pose), _room(0.05)
    aligned = mm.grid_metrics(est, ref, tau=0.05, est_to_ref=pose)
    assert aligned.f1 >= 0.97 and aligned.coverage >= 0.97
    assert aligned.resampled_from == f"0.05 m cells, est_to_ref {tuple(float(v) for v in pose)}"
    as_is = mm.grid_metrics(est, ref, tau=0.05)  # the frames taken as one: the walls do not match
    assert as_is.f1 < 0.3
    # the resampled map: the room's walls at x = 2.0 .. 2.1 in the reference frame
    on_ref = mm.resample_map(est, ref, est_to_ref=pose)
    assert on_ref.resolution == 0.05 and on_ref.value_at(2.05, 0.0) == 100 and on_ref.value_at(1.0, 0.5) == 0
    assert on_ref.value_at(2.6, 2.6) == -1


# ---------------------------------------------------------------- 3D


def _box():
    return o3d.geometry.TriangleMesh.create_box(2.0, 1.0, 1.0)  # corner at the origin


def test_point_to_mesh_distances_and_accuracy():
    offsets = np.array([0.0, 0.01, 0.019, 0.03, 0.049, 0.06, 0.2])
    above = np.stack([np.full(7, 1.0), np.full(7, 0.5), 1.0 + offsets], 1)  # above the top face
    corner = np.array([[2.012, 1.009, 0.5]])  # beside a vertical edge: 0.015 m from it
    inside = np.array([[1.0, 0.5, 0.5]])  # box centre: 0.5 m from the nearest faces
    points = np.vstack([above, corner, inside])
    d = mm.point_to_mesh_distances(points, _box())
    expected = np.concatenate([offsets, [0.015, 0.5]])
    assert np.allclose(d, expected, atol=2e-6)
    acc = mm.map_accuracy(points, _box(), taus=(0.02, 0.05))
    assert acc["points"] == 9
    assert acc["accuracy"]["0.02"] == pytest.approx(4 / 9)  # 0, 0.01, 0.019, 0.015
    assert acc["accuracy"]["0.05"] == pytest.approx(6 / 9)
    assert acc["distance_m"]["max"] == pytest.approx(0.5, abs=1e-6)
    mesh = _box()
    arrays = (np.asarray(mesh.vertices), np.asarray(mesh.triangles))
    assert np.allclose(mm.point_to_mesh_distances(points, arrays), d)


def test_empty_mesh_is_refused():
    with pytest.raises(mm.MapMetricError, match="no triangles"):
        mm.point_to_mesh_distances(np.zeros((1, 3)), o3d.geometry.TriangleMesh())


def test_completeness_of_visible_samples():
    xs, ys = np.meshgrid(np.round(np.arange(0.0, 2.01, 0.1), 6), np.round(np.arange(0.0, 1.01, 0.1), 6))
    samples = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], 1)  # 21 x 11 on the top face
    seen = samples[samples[:, 0] <= 0.95] + [0.0, 0.0, 0.01]  # the map saw x <= 0.9, 1 cm high
    c = mm.completeness(samples, seen, taus=(0.02, 0.05, 0.15))
    assert c["samples"] == 231
    assert c["completeness"]["0.02"] == pytest.approx(10 / 21)
    assert c["completeness"]["0.05"] == pytest.approx(10 / 21)
    assert c["completeness"]["0.15"] == pytest.approx(11 / 21)  # x = 1.0 is 0.1005 m away


def test_chamfer_and_hausdorff():
    a = np.array([[0.0, 0, 0], [1, 0, 0]])
    b = np.array([[0.0, 0, 0.1], [1, 0, 0], [5, 0, 0]])
    r = mm.chamfer_hausdorff(a, b)
    assert r["mean_a_to_b_m"] == pytest.approx(0.05)
    assert r["mean_b_to_a_m"] == pytest.approx(4.1 / 3)
    assert r["chamfer_m"] == pytest.approx((0.05 + 4.1 / 3) / 2)
    assert r["hausdorff_m"] == pytest.approx(4.0)


def test_visible_samples_are_the_faces_seen():
    box = _box()
    above = np.array([[1.0, 0.5, 3.0]])
    dirs = mm.band_directions((-89.0, -20.0), n_elevation=40, n_azimuth=180)
    samples = mm.visible_surface_samples(box, above, directions=dirs, voxel=0.02)
    assert len(samples) > 200
    assert np.allclose(samples[:, 2], 1.0, atol=1e-5)  # only the top face is visible from above
    # a map holding the top face (1 cm grid) is complete against what was visible ...
    xs, ys = np.meshgrid(np.arange(0.0, 2.001, 0.01), np.arange(0.0, 1.001, 0.01))
    top = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], 1)
    assert mm.completeness(samples, top, taus=(0.02,))["completeness"]["0.02"] == 1.0
    # ... but covers only the top face's share (2 of 10 m^2) of the whole surface
    every_face = np.asarray(box.sample_points_uniformly(4000).points)
    share = mm.completeness(every_face, top, taus=(0.02,))["completeness"]["0.02"]
    assert share == pytest.approx(0.2, abs=0.04)
    # out of range: nothing visible
    assert len(mm.visible_surface_samples(box, above, directions=dirs, max_range=1.0)) == 0


def test_band_directions_are_unit_rays_in_the_band():
    d = mm.band_directions((-15.0, 15.0), n_elevation=16, n_azimuth=720)
    assert d.shape == (16 * 720, 3)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    el = np.degrees(np.arcsin(d[:, 2]))
    assert el.min() == pytest.approx(-15.0) and el.max() == pytest.approx(15.0)
    with pytest.raises(mm.MapMetricError, match="elevation"):
        mm.band_directions((10.0, -10.0))


def test_observable_recall_counts_only_surfaces_facing_reachable_space():
    from navlog.analysis.metrics.maps import grid_metrics
    from navlog.replay.occupancy_map import OccupancyMap

    ref = np.zeros((20, 20), dtype=np.int8)
    ref[:3, :] = ref[-3:, :] = ref[:, :3] = ref[:, -3:] = 100  # walls three cells thick
    est = np.full((20, 20), -1, dtype=np.int8)
    est[3:17, 3:17] = 0
    est[2, 2:18] = est[17, 2:18] = est[2:18, 2] = est[2:18, 17] = 100  # only the inner faces
    m = grid_metrics(OccupancyMap(est, 0.05), OccupancyMap(ref, 0.05), tau=0.0, seed_xy=(0.5, 0.5))
    inner = 4 * 16 - 4
    assert m.counts["ref_occupied_observable"] == inner  # the inner ring, corners touching diagonally
    assert m.precision == 1.0
    assert m.recall == pytest.approx(m.counts["matched_ref_occupied"] / int((ref == 100).sum()))
    assert m.recall < 0.5
    assert m.recall_observable == 1.0 and m.f1_observable == 1.0


def _margin_room(margin_cells: int) -> np.ndarray:
    """A 4 m x 4 m room at 0.05 m: walls 0.1 m thick (2 cells) around free space, plus a 0.5 m pillar; the
    reference's obstacles grown by ``margin_cells`` into the free space (a safety margin)."""
    data = np.zeros((100, 100), dtype=np.int8)
    data[:10, :] = data[-10:, :] = data[:, :10] = data[:, -10:] = 100  # outside the room
    data[45:55, 45:55] = 100
    occupied = data == 100
    if margin_cells:
        from scipy import ndimage

        occupied = ndimage.distance_transform_edt(~occupied) <= margin_cells
    return np.where(occupied, 100, 0).astype(np.int8)


def test_a_reference_with_a_safety_margin_is_named():
    walls = _margin_room(0)
    # a laser's map: only the surfaces facing the room (one cell) are occupied, the rest free or unknown
    from scipy import ndimage

    surface = (walls == 100) & ndimage.binary_dilation(walls == 0, structure=np.ones((3, 3), bool))
    est = OccupancyMap(np.where(surface, 100, np.where(walls == 0, 0, -1)).astype(np.int8), 0.05)
    plain = mm.grid_metrics(est, OccupancyMap(walls, 0.05), tau=0.05)
    assert plain.precision == 1.0 and plain.recall_observable == 1.0
    assert plain.warnings == () and "warnings" not in plain.to_dict()  # metrics.json as before
    inflated = mm.grid_metrics(est, OccupancyMap(_margin_room(3), 0.05), tau=0.05)
    # the mapped walls are 3 cells inside the inflated obstacles: the observable recall falls to 0
    assert inflated.recall_observable == 0.0
    assert mm.reference_margin_m(surface, _margin_room(3) == 100, 0.05) == pytest.approx(0.15, abs=0.03)
    assert len(inflated.warnings) == 1 and "0.1" in inflated.warnings[0]
    assert "safety margin" in inflated.warnings[0] and "--margin 0" in inflated.warnings[0]
    assert inflated.to_dict()["warnings"] == list(inflated.warnings)
    # a margin within tau (one cell) is not named
    assert mm.grid_metrics(est, OccupancyMap(_margin_room(1), 0.05), tau=0.05).warnings == ()
