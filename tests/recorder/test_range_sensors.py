"""The laser and the LiDAR in a worker process: the same log as in one process, and failures named."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.recorder import range_sensors, sim
from navlog.recorder.range_sensors import (
    LIDAR,
    SCAN,
    SensorWorker,
    _Ring,
    start_range_sensors,
)
from navlog.recorder.record import prepare, record
from navlog.recorder.robot import load_robot
from navlog.recorder.world import load_world
from navlog.replay.io import open_log
from navlog.replay.runtime.executor import Node

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]


class _Listen(Node):
    """Subscribes to the scan and the cloud, so that the simulator waits for them and builds their objects."""

    name = "listen"

    def __init__(self) -> None:
        super().__init__()
        self.got: list[tuple[str, int, int]] = []  # (topic, time, ranges or points)

    def setup(self) -> None:
        self.subscribe("/scan", lambda msg, t: self.got.append(("/scan", t, len(msg.ranges))))
        self.subscribe("/livox/lidar", lambda msg, t: self.got.append(("/livox/lidar", t, msg.width)))


def _setup(scenario: str, seconds: float):
    setup = prepare("indoor_room", "go2", scenario, seed=11)
    setup.scenario = dataclasses.replace(setup.scenario, max_duration=seconds)
    return setup


@pytest.mark.parametrize("subscribed", [False, True], ids=["only-recorded", "subscribed"])
def test_the_worker_writes_the_bytes_of_one_process(tmp_path: Path, subscribed: bool, monkeypatch) -> None:
    logs, heard = [], []
    ahead_default = sim.MAX_AHEAD
    # the worker with room to fall behind, the worker waited for at once, and no worker
    for worker, ahead in ((True, ahead_default), (True, 1), (False, 0)):
        if subscribed and ahead == 1:
            continue  # nothing is published before it is computed
        monkeypatch.setattr(sim, "MAX_AHEAD", ahead)
        listen = _Listen()
        out = tmp_path / f"{worker}-{ahead}.mcap"
        res = record(
            _setup("mapping", 2.0),
            out,
            progress=False,
            sensor_worker=worker,
            live_nodes=[listen] if subscribed else (),
        )
        assert res.sim_s == 2.0
        logs.append(out.read_bytes())
        heard.append(listen.got)
    assert all(log == logs[-1] for log in logs)
    with open_log(tmp_path / f"True-{ahead_default}.mcap") as reader:
        scans = [(e.time_ns, len(e.msg.ranges)) for e in reader.messages(["/scan"])]
        clouds = [e.time_ns for e in reader.messages(["/livox/lidar"])]
    assert scans == [(t * 100_000_000, 720) for t in range(21)]  # 10 Hz from t = 0, 720 beams
    assert clouds == [t * 100_000_000 for t in range(1, 21)]  # a sweep ends every 100 ms after the first
    if subscribed:  # the listener heard every scan and sweep at its stamp, the same in both runs
        assert heard[0] == heard[-1]
        assert [(t, n) for topic, t, n in heard[0] if topic == "/scan"] == scans
        assert [t for topic, t, _ in heard[0] if topic == "/livox/lidar"] == clouds
        assert all(n == 16 * 720 for topic, _, n in heard[0] if topic == "/livox/lidar")  # every ray returns indoors
    else:
        assert heard == [[], [], []]


@pytest.mark.parametrize("cpus", [2, 1])
def test_the_simulators_process_never_imports_open3d_unless_on_one_cpu(tmp_path: Path, cpus: int) -> None:
    """By default the worker is used when the process may run on more than one CPU: on one, it would only
    add its start-up and messages to that CPU's work, so the sensors stay in the simulator's process."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < cpus:
        pytest.skip(f"needs {cpus} CPUs")
    code = (
        "import dataclasses, os, sys\n"
        f"os.sched_setaffinity(0, {set(allowed[:cpus])!r})\n"
        "from navlog.recorder.record import prepare, record\n"
        "s = prepare('indoor_room', 'go2', 'mapping', seed=11)\n"
        "s.scenario = dataclasses.replace(s.scenario, max_duration=0.5)\n"
        f"record(s, {str(tmp_path / 'x.mcap')!r}, progress=False)\n"
        "print('open3d' in sys.modules, 'mujoco' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(cpus == 1), "True"]


def _worker() -> SensorWorker:
    ranges = start_range_sensors(load_world("indoor_room"), load_robot("go2"), 3, False, worker=True)
    assert isinstance(ranges, SensorWorker)
    return ranges


def _scan_from_the_origin(ranges) -> np.ndarray:
    pose = np.eye(4)
    pose[2, 3] = 0.3
    return ranges.result(ranges.request(SCAN, (0, pose, False)))


def test_a_scan_from_the_worker_equals_one_cast_here() -> None:
    here = start_range_sensors(load_world("indoor_room"), load_robot("go2"), 3, False, worker=False)
    worker = _worker()
    try:
        got = _scan_from_the_origin(worker)
    finally:
        worker.close()
    assert worker._process.returncode == 0  # ended by the closed pipe, and waited for: no zombie
    expected = _scan_from_the_origin(here)
    assert got.dtype == np.float32 and len(got) == 720
    np.testing.assert_array_equal(got, expected)
    assert np.min(got) > 0.12 and np.isfinite(got).sum() > 300  # walls and obstacles around, none inside the body


def test_an_error_in_the_worker_is_raised_with_its_traceback() -> None:
    worker = _worker()
    with pytest.raises(NavlogError, match=r"sensor worker \(the laser and LiDAR process, pid \d+\) failed:") as info:
        # a sweep with one time and no pose: the worker cannot read the poses it is told of
        worker.result(worker.request("lidar", (0, 0, (0.0,), np.zeros((0, 4, 4)), True)))
    assert "Traceback" in str(info.value) and "ValueError" in str(info.value)
    assert worker._process.returncode is not None


def test_a_worker_killed_mid_recording_is_an_error_naming_it(tmp_path: Path, monkeypatch) -> None:
    real = SensorWorker.request
    killed: list[SensorWorker] = []

    def request(self: SensorWorker, kind: str, args: tuple) -> int:
        ticket = real(self, kind, args)
        if ticket == 10:
            os.kill(self._process.pid, signal.SIGKILL)
            killed.append(self)
        return ticket

    monkeypatch.setattr(SensorWorker, "request", request)
    with pytest.raises(NavlogError, match=r"sensor worker .* ended unexpectedly \(exit code -9\)"):
        record(_setup("mapping", 3.0), tmp_path / "run.mcap", progress=False, sensor_worker=True)
    assert killed and killed[0]._process.returncode == -9
    assert list(tmp_path.iterdir()) == []  # the partial file is removed, as for any failed recording


def test_the_command_line_chooses_where_the_sensors_run_and_the_log_is_the_same(tmp_path: Path) -> None:
    scenario = tmp_path / "short.yaml"
    scenario.write_text("name: short\nkind: teleop\ncommands: [{duration: 1.0, cmd: [0.2, 0, 0.1]}]\n")
    logs = []
    for where in ("worker", "in-process"):
        out = tmp_path / f"{where}.mcap"
        proc = subprocess.run(
            [sys.executable, "-m", "navlog.cli", "-q", "record", "--scenario", str(scenario), "--seed", "4"]
            + ["--sensors", where, "-o", str(out)],
            cwd=REPO,
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr
        logs.append(out.read_bytes())
    assert logs[0] == logs[1]
    with open_log(tmp_path / "worker.mcap") as reader:
        # 2 s of sim time (the 1 s command, then the stop): scans from t = 0 at 10 Hz, sweeps after the first
        assert reader.topics["/scan"].count == 21 and reader.topics["/livox/lidar"].count == 20
    bad = subprocess.run(
        [sys.executable, "-m", "navlog.cli", "record", "--sensors", "gpu", "-o", str(tmp_path / "x.mcap")],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "invalid choice: 'gpu'" in bad.stderr and "Traceback" not in bad.stderr


def test_the_ring_puts_results_in_order_and_never_over_one_not_taken() -> None:
    ring = _Ring(100)
    assert [ring.place(t, 30, 0) for t in range(3)] == [0, 30, 60]
    assert ring.place(3, 30, 0) is None  # 10 bytes left at the end, none at the start: nothing taken yet
    assert ring.place(3, 10, 0) == 90  # fits exactly at the end
    assert ring.place(4, 25, 1) == 0  # result 0 taken: its 30 bytes at the start are free again
    assert ring.place(5, 6, 1) is None  # 5 bytes before result 1 (at 30) is all there is
    assert ring.place(5, 35, 3) == 25  # 1 and 2 taken: room from 25 to the start of 3 (at 90)
    assert ring.place(6, 31, 6) == 0  # all taken: from the start again
    assert ring.place(7, 101, 7) is None  # larger than the ring


def _sweep_request(t_ns: int, frame: int, x: float) -> tuple:
    pose = np.eye(4)
    pose[:3, 3] = (x, 0.0, 0.3)
    n = 22  # the poses of a 10 Hz sweep: 20 ticks and two around it
    times = tuple((k - n + 1) * 0.005 for k in range(n))
    return (t_ns, frame, times, np.repeat(pose[None], n, axis=0), True)


@pytest.mark.parametrize(
    "ring_bytes", [None, 8192, 0, "no shared memory"], ids=["ring", "scans-only", "no-ring", "no-shared-memory"]
)
def test_results_come_through_the_ring_or_the_pipe_with_the_same_bytes(ring_bytes, monkeypatch) -> None:
    """Scans (3 kB) and sweeps (250 kB) in the default ring, scans only in a ring of 8 kB, and everything
    through the pipe with no ring, or no shared memory at all (a file-size limit of 0 forbids it); the
    requests, made without waiting, are more than the request pipe holds (400 sweeps of 2.8 kB: more than
    its 1 MiB), so the results must be taken while the queued ones are sent."""
    if ring_bytes == "no shared memory":
        monkeypatch.setattr(range_sensors, "_shared_file", lambda size: None)
        ring_bytes = None
        piped = 800
    else:
        piped = {None: 0, 8192: 400, 0: 800}[ring_bytes]
    world, robot = load_world("indoor_room"), load_robot("go2")
    here = start_range_sensors(world, robot, 5, True, worker=False)
    spec = here.sensors.spec  # type: ignore[union-attr]
    worker = SensorWorker(spec, ring_bytes=ring_bytes)
    requests = []
    for k in range(400):
        requests.append((LIDAR, _sweep_request(k * 100_000_000, k, 0.001 * k)))
        scan_pose = np.eye(4)
        scan_pose[:3, 3] = (0.001 * k, 0.0, 0.3)
        requests.append((SCAN, (k * 100_000_000, scan_pose, True)))
    got: list = []

    def run() -> None:
        tickets = [worker.request(kind, args) for kind, args in requests]
        got.extend(worker.result(t) for t in tickets)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=120)
    stuck = thread.is_alive()
    worker.close()  # also ends a stuck thread: its pipes close
    assert not stuck, "the worker and this process wait on each other"
    expected = [here.result(here.request(kind, args)) for kind, args in requests]
    assert all(isinstance(g, bytes) for g in got) and got == expected
    assert len(got[0]) > 200_000 and len(got[1]) < 4000  # a sweep of 16 x 720 points, a scan of 720 ranges
    assert worker.piped == piped
    assert worker._process.returncode == 0


def test_requests_the_pipe_has_no_room_for_wait_in_this_process_while_the_worker_is_stopped() -> None:
    """The worker stopped (as if still importing Open3D): 400 sweeps of 3 kB are more than the request
    pipe holds (1 MiB, one 4 KiB page a request), yet every request returns at once, the rest queued
    here; resumed, the worker answers them all, in order, with the bytes of one process."""
    world, robot = load_world("indoor_room"), load_robot("go2")
    here = start_range_sensors(world, robot, 5, True, worker=False)
    worker = SensorWorker(here.sensors.spec)  # type: ignore[union-attr]
    requests = [(LIDAR, _sweep_request(k * 100_000_000, k, 0.001 * k)) for k in range(400)]
    try:
        os.kill(worker._process.pid, signal.SIGSTOP)
        try:
            tickets = [worker.request(kind, args) for kind, args in requests]
            assert tickets == list(range(400))
            assert 400 - (1 << 20) // 4096 <= len(worker._unsent) < 400  # the pipe took what it holds
            assert not worker.ready(0)
        finally:
            os.kill(worker._process.pid, signal.SIGCONT)
        got = [worker.result(t) for t in tickets]
        assert not worker._unsent
    finally:
        worker.close()
    assert got == [here.result(here.request(kind, args)) for kind, args in requests]


def _helper_threads_cpu_ticks(pid: int) -> int:
    """CPU time (clock ticks) of a process's threads other than its main one."""
    ticks = 0
    for tid in os.listdir(f"/proc/{pid}/task"):
        if int(tid) != pid:
            fields = Path(f"/proc/{pid}/task/{tid}/stat").read_text().rsplit(")", 1)[1].split()
            ticks += int(fields[11]) + int(fields[12])
    return ticks


def test_once_the_simulation_has_ended_the_worker_casts_on_every_core_with_the_same_bytes() -> None:
    """150 sweeps before ``ending``, 150 after: the same bytes as one process, and with more than one
    CPU only the later ones keep the worker's other threads busy (Open3D's, about 7 ticks)."""
    world, robot = load_world("indoor_room"), load_robot("go2")
    here = start_range_sensors(world, robot, 5, True, worker=False)
    worker = SensorWorker(here.sensors.spec)  # type: ignore[union-attr]
    requests = [(LIDAR, _sweep_request(k * 100_000_000, k, 0.001 * k)) for k in range(300)]
    try:
        first = [worker.result(worker.request(kind, args)) for kind, args in requests[:150]]
        before = _helper_threads_cpu_ticks(worker._process.pid)
        worker.ending()
        rest = [worker.result(worker.request(kind, args)) for kind, args in requests[150:]]
        after = _helper_threads_cpu_ticks(worker._process.pid)
    finally:
        worker.close()
    worker.ending()  # after close: nothing
    here.ending()  # in one process there is nothing still to come: no change
    assert first + rest == [here.result(here.request(kind, args)) for kind, args in requests]
    assert worker._process.returncode == 0
    if len(os.sched_getaffinity(0)) > 1:
        assert before <= 1 < after


def test_requests_after_the_worker_failed_raise_its_error_not_a_broken_pipe() -> None:
    worker = _worker()
    worker.request("lidar", (0, 0, (0.0,), np.zeros((0, 4, 4)), True))  # the worker fails on it and ends
    worker._process.wait(timeout=60)
    pose = np.eye(4)
    with pytest.raises(NavlogError, match=r"sensor worker \(the laser and LiDAR process, pid \d+\) failed:") as info:
        worker.request(SCAN, (0, pose, True))  # its pipe is broken
    assert "Traceback" in str(info.value) and "ValueError" in str(info.value)
    assert worker._process.returncode == 0
