"""The occupancy grid's updates in a child process: the same bits as in one process, outcomes in order,
the grid handed over once the child has started, errors named, no process left behind."""

from __future__ import annotations

import math
import select

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay.mapping.occupancy import GridTooLarge, OccupancyGrid2D, OccupancyParams
from navlog.replay.workers.grid import GridWorker

PARAMS = OccupancyParams(resolution=0.05, clamp=(0.12, 0.97))
ANGLES = -math.pi + np.arange(360) * (2 * math.pi / 360)


def room_scan(x: float, y: float) -> np.ndarray:
    """Ranges from (x, y) (heading 0) to the walls of a 6 m x 4 m room centred on the origin, some missing."""
    c, s = np.cos(ANGLES), np.sin(ANGLES)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (3.0 - x) / c, np.where(c < 0, (-3.0 - x) / c, np.inf))
        ty = np.where(s > 0, (2.0 - y) / s, np.where(s < 0, (-2.0 - y) / s, np.inf))
    r = np.minimum(tx, ty).astype(np.float32)
    r[::37] = np.inf  # no return
    r[5] = np.nan
    return r


def pose(x: float, y: float, yaw: float = 0.0) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=np.float64)


# scans along a path, one far off (refused: the grid would exceed its budget)
SCANS = [
    (pose(-2.0 + 0.25 * k, 0.1 * math.sin(k), 0.0), room_scan(-2.0 + 0.25 * k, 0.1 * math.sin(k))) for k in range(12)
]
SCANS.insert(6, (pose(5e6, 0.0), room_scan(0.0, 0.0)))


def reference() -> tuple[OccupancyGrid2D, list[bool]]:
    grid, taken = OccupancyGrid2D(PARAMS), []
    for T, r in SCANS:
        try:
            grid.insert_scan(T, ANGLES, r, 0.1, 8.0)
            taken.append(True)
        except GridTooLarge:
            taken.append(False)
    return grid, taken


def same_grid(a: OccupancyGrid2D, b: OccupancyGrid2D) -> bool:
    return (
        a.logodds.tobytes() == b.logodds.tobytes()
        and a.seen.tobytes() == b.seen.tobytes()
        and np.array_equal(a.origin, b.origin)
        and a.stats == b.stats
    )


def wait_started(worker: GridWorker) -> None:
    """Wait (up to 30 s) until the child has said it is ready; the next scan then hands the grid over."""
    assert worker._process is not None and worker._process.stdout is not None
    assert select.select([worker._process.stdout], [], [], 30.0)[0], "the child did not start"


@pytest.mark.parametrize("hand_over_at", [None, 0, 4, 9])
def test_the_child_gives_the_same_grid_map_and_outcomes_as_one_process(hand_over_at):
    want, want_taken = reference()
    worker = GridWorker(PARAMS, spawn=hand_over_at is not None)
    taken: list[bool] = []
    maps = []
    try:
        for k, (T, r) in enumerate(SCANS):
            if k == hand_over_at:
                wait_started(worker)
            worker.insert_scan(T, ANGLES, r, 0.1, 8.0)
            if k in (hand_over_at, 3, 10):
                maps.append(worker.to_map("map"))
                taken += worker.outcomes()
        assert worker.in_child == (hand_over_at is not None)
        taken += worker.outcomes()
        got = worker.snapshot()
    finally:
        worker.close()
    assert taken == want_taken and taken.count(False) == 1
    assert same_grid(got, want)
    final = got.to_map("map")
    assert final.data.tobytes() == want.to_map("map").data.tobytes() and (final.data == 100).sum() > 300
    assert all(m is not None and m.data.shape[0] > 0 for m in maps)


def test_an_empty_grid_has_no_map():
    worker = GridWorker(PARAMS)
    try:
        wait_started(worker)
        worker.insert_scan(pose(5e6, 0.0), ANGLES, room_scan(0.0, 0.0), 0.1, 8.0)  # refused: still empty
        assert worker.in_child and worker.to_map("map") is None and worker.outcomes() == [False]
    finally:
        worker.close()


def test_a_child_that_dies_is_named_and_leaves_nothing_behind():
    worker = GridWorker(PARAMS)
    wait_started(worker)
    worker.insert_scan(SCANS[0][0], ANGLES, SCANS[0][1], 0.1, 8.0)
    process = worker._process
    assert process is not None
    process.kill()
    process.wait()
    with pytest.raises(NavlogError, match=r"occupancy grid process \(pid \d+\) ended unexpectedly"):
        for T, r in SCANS:  # the pipe may take a few scans before the write fails
            worker.insert_scan(T, ANGLES, r, 0.1, 8.0)
        worker.to_map("map")
    assert worker._process is None


def test_an_error_in_the_child_comes_back_with_its_traceback():
    worker = GridWorker(PARAMS)
    try:
        wait_started(worker)
        worker.insert_scan(SCANS[0][0], ANGLES, SCANS[0][1], 0.1, 8.0)
        worker._send(ord("X"), b"")  # a request the child does not know
        with pytest.raises(NavlogError, match=r"(?s)occupancy grid process \(pid \d+\) failed:.*unknown request"):
            worker.to_map("map")
    finally:
        worker.close()


def test_closing_ends_the_child_and_mismatched_beams_are_refused_either_way():
    worker = GridWorker(PARAMS)
    process = worker._process
    assert process is not None
    worker.close()
    assert process.poll() is not None
    for spawn in (False, True):
        worker = GridWorker(PARAMS, spawn=spawn)
        try:
            if spawn:
                wait_started(worker)
            with pytest.raises(ValueError, match="360 beam angles for 3 ranges"):
                worker.insert_scan(pose(0, 0), ANGLES, np.ones(3), 0.1, 8.0)
        finally:
            worker.close()


def test_a_child_whose_parent_is_gone_ends_quietly():
    """An interrupted replay closes the pipes before the child has even said it is ready: no traceback."""
    import subprocess
    import sys

    from navlog.replay.workers import grid as grid_process

    child = subprocess.Popen(
        [sys.executable, "-c", grid_process._CHILD],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert child.stdout is not None and child.stdin is not None and child.stderr is not None
    child.stdout.close()  # the child's "ready" then meets a closed pipe
    err = child.stderr.read()
    child.stdin.close()
    assert child.wait(timeout=30) == 0 and err == b""


@pytest.mark.parametrize("how", ["no interpreter", "ends at once"])
def test_without_a_child_the_grid_stays_in_the_process(monkeypatch, how):
    """The child process is an optimisation: when it cannot start, or ends before it is ready, the scans go
    into the grid in this process and give the same grid."""
    import sys

    from navlog.replay.workers import grid as grid_process

    if how == "no interpreter":
        monkeypatch.setattr(sys, "executable", "/nonexistent/python")
    else:
        monkeypatch.setattr(grid_process, "_CHILD", "import sys; sys.exit(3)")
    want, want_taken = reference()
    worker = GridWorker(PARAMS)
    if worker._process is not None:  # it ends at once: wait for that, so the next scan sees it
        assert worker._process.wait(timeout=30) == 3
    try:
        for T, r in SCANS:
            worker.insert_scan(T, ANGLES, r, 0.1, 8.0)
        assert not worker.in_child and worker._process is None
        assert worker.outcomes() == want_taken and same_grid(worker.snapshot(), want)
    finally:
        worker.close()


def test_maps_asked_for_without_waiting_come_in_order_and_at_most_some_stay_owed():
    want, _ = reference()
    worker = GridWorker(PARAMS)
    got: list[tuple[int, bytes]] = []
    try:
        wait_started(worker)
        for k, (T, r) in enumerate(SCANS):
            worker.insert_scan(T, ANGLES, r, 0.1, 8.0)
            if k in (2, 5, 8):
                worker.request_map("map", lambda m, k=k: got.append((k, m.data.tobytes())))
        worker.request_map("map", lambda m: got.append((99, m.data.tobytes())))
        worker.poll(at_most=1)  # waits for the oldest until one is owed
        assert len(worker._requests) == 1 and [k for k, _ in got] == [2, 5, 8]
        worker.poll(at_most=0)
        assert not worker._requests and [k for k, _ in got] == [2, 5, 8, 99]
    finally:
        worker.close()
    assert got[-1][1] == want.to_map("map").data.tobytes()


def test_the_child_never_loads_a_compiler():
    """The grid's update is NumPy: numba's LLVM library is never in the child's memory."""
    worker, here = GridWorker(PARAMS), OccupancyGrid2D(PARAMS)
    try:
        wait_started(worker)
        for T, r in SCANS[:4]:
            worker.insert_scan(T, ANGLES, r, 0.1, 8.0)
            here.insert_scan(T, ANGLES, r, 0.1, 8.0)
        assert worker.in_child and all(worker.outcomes())
        got = worker.snapshot()
        assert worker._process is not None
        maps = open(f"/proc/{worker._process.pid}/maps").read()
    finally:
        worker.close()
    assert "llvmlite" not in maps and "numpy" in maps  # (the mapped libraries)
    assert same_grid(got, here)
