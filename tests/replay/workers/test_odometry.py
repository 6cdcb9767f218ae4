"""Frames completed in a child process: the same bits as ``LidarOdometry.process`` here (frames planned
ahead from the odometry track, or one at a time from the constant velocity and the gyro), results in
the order submitted, the maps at the end, large frames both ways at once without the processes
waiting for each other, errors named."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay.geometry import make_transform, quat_from_rpy
from navlog.replay.mapping.lidar_odometry import (
    ConstantVelocity,
    GyroTrack,
    LidarOdometry,
    LidarOdometryParams,
    MotionPrior,
    PoseTrack,
)
from navlog.replay.mapping.lidar_odometry.deskew import prior_motion
from navlog.replay.mapping.lidar_odometry.odometry import FrameResult, SweepPlan
from navlog.replay.mapping.lidar_odometry.sweep import prepare_sweep
from navlog.replay.workers.odometry import NAME, OdometryWorker

pytestmark = pytest.mark.slow

MOUNT = make_transform((0.2, 0.0, 0.4), quat_from_rpy(0.0, 0.1, 0.05))
PARAMS = LidarOdometryParams(save_every_n_frames=4)
START_NS = 1_000_000_000


def base_pose(t: float) -> np.ndarray:
    """base_link in odom ``t`` s after the start: 0.5 m/s forward, turning 0.2 rad/s."""
    return make_transform((0.5 * t, 0.1 * t * t, 0.0), quat_from_rpy(0.0, 0.0, 0.2 * t))


def frame(k: int, n: int = 6000) -> tuple[int, np.ndarray, np.ndarray]:
    """Frame ``k`` (10 Hz) inside a 6 m x 4 m x 3 m room: (stamp ns, points in the sensor frame, per-point
    times over a 0.1 s sweep)."""
    rng = np.random.default_rng(k)
    az, el = rng.uniform(-np.pi, np.pi, n), rng.uniform(-0.5, 0.5, n)
    rays = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    sensor = base_pose(0.1 * k + 0.05) @ MOUNT  # seen from mid-sweep
    o, r = sensor[:3, 3], rays @ sensor[:3, :3].T
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(r > 0, (np.array([3.0, 2.0, 3.0]) - o) / r, (np.array([-3.0, -2.0, 0.0]) - o) / r)
    hit = np.min(np.where(t > 0, t, np.inf), axis=1)
    return START_NS + 100_000_000 * k, rays * hit[:, None], np.sort(rng.uniform(0.0, 0.1, n))


def tracks(gyro_only: bool) -> MotionPrior:
    """The odometry track at 50 Hz over every frame, or the gyro's alone (then the constant velocity
    gives the translation)."""
    odom, gyro = PoseTrack(), GyroTrack()
    for i in range(-10, 120):
        t_ns = START_NS + 20_000_000 * i
        odom.add(t_ns, base_pose(i * 0.02))
        gyro.add(t_ns, np.array([0.0, 0.0, 0.2]))
    return MotionPrior(gyro, None) if gyro_only else MotionPrior(None, odom)


def bits(r: FrameResult) -> tuple:
    return (r.stamp_ns, r.pose.tobytes(), r.registered.tobytes(), r.fitness, r.rmse, r.keyframe, r.velocity.tobytes())


@pytest.mark.parametrize("gyro_only", [False, True])
def test_the_child_completes_frames_with_the_bits_of_this_process(gyro_only):
    prior = tracks(gyro_only)
    here = LidarOdometry(PARAMS, MOUNT)
    want = [here.process(*frame(k), prior) for k in range(10)]
    assert all(w is not None for w in want) and here.registrations == 9
    assert max(w.fitness for w in want[1:]) > 0.9  # the frames register onto the room

    planner = LidarOdometry(PARAMS, MOUNT)
    worker = OdometryWorker(PARAMS, planner.initial_pose)
    got = []
    try:
        if not gyro_only:  # every motion from the odometry track: all planned before any completes
            plans = [planner.plan(*frame(k), prior, settled=False) for k in range(10)]
            assert all(isinstance(p, SweepPlan) for p in plans)
            for plan in plans:
                worker.submit(plan, prepare_sweep(plan.job))
            assert len(worker) == 10
            for plan in plans:
                got.append(worker.take()[0])
                planner.adopt(plan, got[-1], {})
        else:  # the translation from the constant velocity: one frame at a time
            assert not isinstance(planner.plan(*frame(0), prior, settled=False), SweepPlan)
            planner = LidarOdometry(PARAMS, MOUNT)
            for k in range(10):
                plan = planner.plan(*frame(k), prior)
                assert isinstance(plan, SweepPlan) and plan.after is None and plan.after_rotation is not None
                worker.submit(plan, prepare_sweep(plan.job))
                result, skipped = worker.take()
                planner.adopt(plan, result, skipped)
                got.append(result)
                # reported at the stamp: moved back by this frame's velocity, with the gyro's rotation
                velocity = ConstantVelocity(result.velocity[:3], result.velocity[3:])
                back = prior_motion(plan.ref_ns, np.array([plan.stamp_ns]), prior, velocity)[0]
                assert (result.registered @ back).tobytes() == result.pose.tobytes()
        points, chunks = worker.maps()
    finally:
        worker.close()
    assert [bits(g) for g in got] == [bits(w) for w in want if w is not None]
    assert planner.poses()[1].tobytes() == here.poses()[1].tobytes() and planner.skipped == here.skipped
    assert points.tobytes() == here.global_map().tobytes() and len(points) > 1000
    assert [c.tobytes() for c in chunks] == [c.tobytes() for c in here.finish_chunks()] and len(chunks) == 3


def test_large_frames_both_ways_at_once_do_not_wait_for_each_other():
    """Two frames of 300 000 points (7 MB each way, kept whole) submitted before either is taken: the
    child writes the first result while the parent writes the second frame, each larger than a pipe holds."""
    planner = LidarOdometry(PARAMS, MOUNT)
    prior = tracks(False)
    plans = [planner.plan(*frame(k, 300_000), prior, settled=False) for k in range(2)]
    worker = OdometryWorker(PARAMS, planner.initial_pose)
    got: list[FrameResult] = []

    def run() -> None:
        for plan in plans:
            assert isinstance(plan, SweepPlan)
            worker.submit(plan, prepare_sweep(plan.job))
        got.extend(worker.take()[0] for _ in plans)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=120)
    try:
        assert not thread.is_alive(), "the two processes waited for each other"
    finally:
        worker.close()
    assert len(got) == 2 and all(g.points_base is not None and len(g.points_base) == 300_000 for g in got)


def test_a_child_that_dies_or_fails_is_named():
    planner = LidarOdometry(PARAMS, MOUNT)
    plan = planner.plan(*frame(0))
    assert isinstance(plan, SweepPlan)
    worker = OdometryWorker(PARAMS, planner.initial_pose)
    assert worker._child is not None and worker._child.process is not None
    worker._child.process.kill()
    worker._child.process.wait()
    with pytest.raises(NavlogError, match=rf"{NAME} \(pid \d+\) ended unexpectedly"):
        worker.submit(plan, prepare_sweep(plan.job))
        worker.take()
    worker.close()
    worker = OdometryWorker(PARAMS, planner.initial_pose)
    try:
        assert worker._child is not None
        worker._child.ask(ord("X"))  # a request the child does not know
        with pytest.raises(NavlogError, match=rf"(?s){NAME} \(pid \d+\) failed:.*unknown request"):
            worker._reply()
    finally:
        worker.close()
