"""Ray: a local Ray (2 CPUs, no dashboard, bound to 127.0.0.1) started once for this module runs a fleet
with the same output bytes and summary as this process, and a Ray worker killed with -9 loses one job."""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path

import pytest

from navlog.analysis.fleet import replay_fleet
from navlog.analysis.fleet.executors import Lost, RayPool, run_jobs, start_local_ray
from tests.analysis.fleet import jobs
from tests.analysis.fleet.conftest import OVERRIDES, folder_bytes

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def ray_local():
    if importlib.util.find_spec("ray") is None:  # not `import ray`: start_local_ray sets Ray up before that
        pytest.skip("ray is not installed (pip install navlog[fleet])")
    ray = start_local_ray(2, runtime_env={"env_vars": {"PYTHONPATH": str(REPO)}})  # the test jobs live in tests/
    yield ray
    ray.shutdown()


def test_the_local_ray_listens_on_the_loopback_address_only(ray_local):
    import psutil

    ray_pids = {p.pid for p in psutil.process_iter(["name", "cmdline"]) if "ray" in " ".join(p.info["cmdline"] or [])}
    ray_pids.add(os.getpid())
    listening = [
        c.laddr.ip for c in psutil.net_connections("tcp") if c.status == psutil.CONN_LISTEN and c.pid in ray_pids
    ]
    assert listening and all(ip in ("127.0.0.1", "::ffff:127.0.0.1", "::1") for ip in listening), listening


LOOPBACK_CHECK = """
import json
import time
import ray  # imported before navlog starts it: Ray has read its settings already
import psutil
from navlog.analysis.fleet.executors import start_local_ray
r = start_local_ray(1)
time.sleep(1.0)
pids = {p.pid for p in psutil.process_iter(["cmdline"]) if any("ray" in a for a in (p.info["cmdline"] or []))}
pids.add(psutil.Process().pid)
print(json.dumps(sorted({c.laddr.ip for c in psutil.net_connections("tcp") if c.status == psutil.CONN_LISTEN and c.pid in pids})))
r.shutdown()
"""


def test_a_local_ray_listens_on_loopback_even_when_ray_was_imported_first(tmp_path):
    """Ray reads its single-machine setting when first imported: a program that imported ray before
    asking navlog for a local Ray still gets servers on 127.0.0.1 only (GCS, raylet, workers, agents)."""
    import subprocess
    import sys

    if importlib.util.find_spec("ray") is None:
        pytest.skip("ray is not installed (pip install navlog[fleet])")
    res = subprocess.run(
        [sys.executable, "-c", LOOPBACK_CHECK], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert res.returncode == 0, res.stderr[-2000:]
    listening = json.loads(res.stdout.strip().splitlines()[-1])
    assert len(listening) >= 1 and set(listening) <= {"127.0.0.1", "::ffff:127.0.0.1", "::1"}, listening


def test_ray_writes_the_same_bytes_and_summary_as_this_process(ray_local, fleet_dir, tmp_path):
    logs = [fleet_dir / "a.mcap", fleet_dir / "trunc.mcap"]
    on_ray = replay_fleet(logs, "mapping", tmp_path / "ray", overrides=OVERRIDES, ray=True, progress=False)
    here = replay_fleet(logs, "mapping", tmp_path / "here", overrides=OVERRIDES, workers=1, progress=False)
    assert on_ray.executor == "Ray" and here.executor == "this process"
    assert [r.status for r in on_ray.results] == ["ok", "failed"]
    assert folder_bytes(tmp_path / "ray") == folder_bytes(tmp_path / "here")
    assert on_ray.summary == here.summary
    assert ray_local.is_initialized()  # a Ray the caller started is left running


def test_a_ray_worker_killed_with_signal_9_loses_its_job_only_and_retries_rerun_it(ray_local, tmp_path):
    results = run_jobs(RayPool(), jobs.die_on_minus_one, [2, -1, 3])
    assert results[0] == (4, 1) and results[2] == (9, 1)
    lost = results[1][0]
    assert isinstance(lost, Lost) and "its Ray worker was lost: WorkerCrashedError" in lost.reason
    marker = tmp_path / "died"
    assert run_jobs(RayPool(), jobs.die_once, [str(marker)], retries=1) == [("ok", 2)]
