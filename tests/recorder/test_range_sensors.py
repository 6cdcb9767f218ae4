"""The laser and the LiDAR in a worker process: the same log as in one process, and failures named.

The transport (requests queued, results through the shared ring or the pipe, in order) is tested with a
handler of its own in tests/replay/workers/test_ring.py."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.recorder import sim
from navlog.recorder.range_sensors import (
    LIDAR,
    RING_RESULTS,
    SCAN,
    SensorWorker,
    _pack_arrays,
    _ring_size,
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
    assert worker.ring.process.returncode == 0  # ended by the closed pipe, and waited for: no zombie
    expected = _scan_from_the_origin(here)
    assert got.dtype == np.float32 and len(got) == 720
    np.testing.assert_array_equal(got, expected)
    assert np.min(got) > 0.12 and np.isfinite(got).sum() > 300  # walls and obstacles around, none inside the body


def test_an_error_in_the_worker_is_raised_with_its_traceback() -> None:
    worker = _worker()
    with pytest.raises(NavlogError, match=r"sensor worker \(pid \d+\) failed:") as info:
        # a sweep with one time and no pose: the worker cannot read the poses it is told of
        worker.result(worker.request("lidar", (0, 0, (0.0,), np.zeros((0, 4, 4)), True)))
    assert "Traceback" in str(info.value) and "ValueError" in str(info.value)
    assert worker.ring.process.returncode is not None


def test_a_worker_killed_mid_recording_is_an_error_naming_it(tmp_path: Path, monkeypatch) -> None:
    real = SensorWorker.request
    killed: list[SensorWorker] = []

    def request(self: SensorWorker, kind: str, args: tuple) -> int:
        ticket = real(self, kind, args)
        if ticket == 10:
            os.kill(self.ring.process.pid, signal.SIGKILL)
            killed.append(self)
        return ticket

    monkeypatch.setattr(SensorWorker, "request", request)
    with pytest.raises(
        NavlogError, match=r"sensor worker \(pid \d+\) ended unexpectedly \(exit code -9\); the recording stops here"
    ):
        record(_setup("mapping", 3.0), tmp_path / "run.mcap", progress=False, sensor_worker=True)
    assert killed and killed[0].ring.process.returncode == -9
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


def _sweep_request(t_ns: int, frame: int, x: float) -> tuple:
    pose = np.eye(4)
    pose[:3, 3] = (x, 0.0, 0.3)
    n = 22  # the poses of a 10 Hz sweep: 20 ticks and two around it
    times = tuple((k - n + 1) * 0.005 for k in range(n))
    return (t_ns, frame, times, np.repeat(pose[None], n, axis=0), True)


def test_the_ring_holds_ring_results_of_the_largest_sweep_so_none_goes_through_the_pipe() -> None:
    """Indoors every ray returns: a sweep of 16 x 720 points, as CDR or as its columns, is the largest result;
    the worker's ring holds ``RING_RESULTS`` of it (with the rest of a page)."""
    here = start_range_sensors(load_world("indoor_room"), load_robot("go2"), 5, True, worker=False)
    cdr = here.result(here.request(LIDAR, _sweep_request(0, 0, 0.0)))
    columns = here.result(here.request(LIDAR, _sweep_request(0, 1, 0.0)[:-1] + (False,)))
    largest = max(len(cdr), len(_pack_arrays(columns)))
    assert largest > 200_000
    assert RING_RESULTS * largest <= _ring_size(here.sensors.spec) < RING_RESULTS * (largest + 4096)  # type: ignore[union-attr]


def test_the_worker_casts_on_one_core_until_the_simulation_has_ended_then_on_every_core(monkeypatch) -> None:
    """The worker's handler asks Open3D for one thread per cast (the simulator's process has the other core)
    until ``ending``, then for all of them (``nthreads=0``), and the ranges are the same either way."""
    from navlog.recorder import range_sensors

    built: list[range_sensors.RangeSensors] = []

    class Recorded(range_sensors.RangeSensors):
        def __init__(self, spec: range_sensors.RangeSensorSpec) -> None:
            super().__init__(spec)
            built.append(self)

    here = start_range_sensors(load_world("indoor_room"), load_robot("go2"), 5, True, worker=False)
    monkeypatch.setattr(range_sensors, "RangeSensors", Recorded)
    spec = range_sensors._spec_bytes(here.sensors.spec)  # type: ignore[union-attr]
    request = range_sensors._request_bytes(LIDAR, _sweep_request(0, 0, 0.0)[:-1] + (False,))
    one_core, every_core = range_sensors.worker_handler(spec), range_sensors.worker_handler(spec)
    assert one_core(request, False) == every_core(request, True)  # each its own noise stream, at its start
    assert [ranges.caster.threads for ranges in built] == [1, 0]
    assert one_core(request, True) == every_core(request, False)
    assert [ranges.caster.threads for ranges in built] == [0, 1]


def test_once_the_simulation_has_ended_the_worker_casts_on_every_core_with_the_same_bytes() -> None:
    """150 sweeps before ``ending``, 150 after: the same bytes as one process."""
    world, robot = load_world("indoor_room"), load_robot("go2")
    here = start_range_sensors(world, robot, 5, True, worker=False)
    worker = SensorWorker(here.sensors.spec)  # type: ignore[union-attr]
    requests = [(LIDAR, _sweep_request(k * 100_000_000, k, 0.001 * k)) for k in range(300)]
    try:
        first = [worker.result(worker.request(kind, args)) for kind, args in requests[:150]]
        worker.ending()
        rest = [worker.result(worker.request(kind, args)) for kind, args in requests[150:]]
    finally:
        worker.close()
    worker.ending()  # after close: nothing
    here.ending()  # in one process there is nothing still to come: no change
    assert first + rest == [here.result(here.request(kind, args)) for kind, args in requests]
    assert worker.ring.process.returncode == 0
