"""A sweep's preparation: into base_link by the mount, deskewed slot by slot, voxel-filtered twice."""

from __future__ import annotations

import numpy as np

from navlog.replay.geometry import make_transform, quat_from_rpy
from navlog.replay.mapping.lidar_odometry.sweep import SweepJob, prepare_sweep

MOUNT = make_transform((0.2, 0.0, 0.4), quat_from_rpy(0.0, 0.1, 0.05))


def sweep(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points on the walls of a 6 m x 4 m x 3 m box around the sensor, over a 0.1 s sweep."""
    rng = np.random.default_rng(seed)
    az = rng.uniform(-np.pi, np.pi, n)
    el = rng.uniform(-0.4, 0.4, n)
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    with np.errstate(divide="ignore"):
        t = np.min(np.abs(np.array([3.0, 2.0, 1.5]) / d), axis=1)
    return d * t[:, None], np.sort(rng.uniform(0.0, 0.1, n))


def motions(slots: int) -> np.ndarray:
    """A turn of 0.2 rad/s and 0.5 m/s forward over the sweep, sampled at ``slots`` times."""
    out = np.empty((slots, 4, 4))
    for k, t in enumerate(np.linspace(-0.05, 0.05, slots)):
        out[k] = make_transform((0.5 * t, 0.0, 0.0), quat_from_rpy(0.0, 0.0, 0.2 * t))
    return out


def jobs() -> list[SweepJob]:
    out = []
    for k, (deskew, scan_voxel, keep) in enumerate([(True, 0.1, True), (True, 0.1, False), (False, 0.0, True)]):
        pts, times = sweep(5000 + 100 * k, k)
        out.append(
            SweepJob(pts, MOUNT, times if deskew else None, motions(20) if deskew else None, 0.05, scan_voxel, keep)
        )
    return out


def test_preparing_moves_deskews_and_filters():
    job = jobs()[0]
    out = prepare_sweep(job)
    assert out.base is not None and out.scan is not None
    # each point: into base_link by the mount, then by the motion of the slot nearest its time
    slot = np.round((job.times - job.times.min()) / (job.times.max() - job.times.min()) * 19).astype(int)
    in_base = job.points @ MOUNT[:3, :3].T + MOUNT[:3, 3]
    want = np.einsum("nij,nj->ni", job.deskew[slot, :3, :3], in_base) + job.deskew[slot, :3, 3]
    np.testing.assert_allclose(out.base, want, rtol=0, atol=1e-12)
    assert np.abs(out.base - in_base).max() > 0.02  # the deskew moved the sweep's ends by centimetres
    # one point per 5 cm voxel, then one per 10 cm voxel of those
    assert len(out.scan) < len(out.fine) < len(job.points)
    keys = np.floor(out.fine / 0.05)  # a mean lies in its voxel
    assert len(np.unique(keys, axis=0)) == len(out.fine)
    assert prepare_sweep(jobs()[1]).base is None and prepare_sweep(jobs()[2]).scan is None
