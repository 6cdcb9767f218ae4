"""A sweep's preparation in a child process: the same bits as in this process, results in the order
submitted, large sweeps both ways at once without the processes waiting for each other, errors named."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay.geometry import make_transform, quat_from_rpy
from navlog.replay.mapping.lidar_odometry.sweep_process import PreparedSweep, SweepJob, SweepWorker, prepare_sweep

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


def same(a: PreparedSweep, b: PreparedSweep) -> bool:
    def bits(x: np.ndarray | None) -> bytes | None:
        return None if x is None else np.ascontiguousarray(x).tobytes()

    return all(bits(getattr(a, f)) == bits(getattr(b, f)) for f in ("base", "fine", "scan"))


def started(worker: SweepWorker) -> SweepWorker:
    """Wait (up to 30 s) until the child has said it is ready."""
    assert worker._child is not None
    deadline = time.monotonic() + 30
    while not worker._child.started():
        assert time.monotonic() < deadline, "the child did not start"
        time.sleep(0.01)
    return worker


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


@pytest.mark.parametrize("spawn", [False, True])
def test_the_child_gives_the_same_bits_in_the_order_submitted(spawn):
    work = jobs()
    worker = SweepWorker(spawn=spawn)
    try:
        if spawn:
            started(worker)
        for job in work:
            worker.submit(job)
        assert len(worker) == 3
        if spawn:
            assert all(done is None for _, done in worker._queue)  # all three went to the child
        got = [worker.take() for _ in work]
    finally:
        worker.close()
    assert all(same(g, prepare_sweep(j)) for g, j in zip(got, work, strict=True))
    assert worker._child is None or worker._child.process is None


def test_large_sweeps_both_ways_at_once_do_not_wait_for_each_other():
    """Two sweeps of 300 000 points (7 MB each way) submitted before either is taken: the child writes
    the first result while the parent writes the second sweep, each larger than a pipe holds."""
    pts, times = sweep(300_000, 7)
    big = SweepJob(pts, MOUNT, times, motions(20), 0.05, 0.1, True)
    worker = started(SweepWorker())
    got: list[PreparedSweep] = []

    def run() -> None:
        worker.submit(big)
        worker.submit(big)
        got.extend(worker.take() for _ in range(2))

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=120)
    try:
        assert not thread.is_alive(), "the two processes waited for each other"
    finally:
        worker.close()
    want = prepare_sweep(big)
    assert len(got) == 2 and all(same(g, want) for g in got)


def test_a_child_that_dies_or_fails_is_named():
    worker = started(SweepWorker())
    assert worker._child is not None
    process = worker._child.process
    assert process is not None
    process.kill()
    process.wait()
    with pytest.raises(NavlogError, match=r"3D sweep process \(pid \d+\) ended unexpectedly"):
        worker.submit(jobs()[0])
        worker.take()
    worker = started(SweepWorker())
    try:
        assert worker._child is not None
        worker._child.ask(ord("X"))  # a request the child does not know
        with pytest.raises(NavlogError, match=r"(?s)3D sweep process \(pid \d+\) failed:.*unknown request"):
            worker._child.reply()
    finally:
        worker.close()
