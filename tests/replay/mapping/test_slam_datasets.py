"""2D SLAM on real buildings: the classic CARMEN datasets of the external data (real laser scans, real
wheel odometry), scored against their corrected trajectories (``NAME.reference.tum``).

Thresholds are measured with ``benchmarks/bench_slam_datasets.py`` (default parameters) with margin;
the odometry figures are the same benchmark's, for the bag's own wheel odometry at the scan stamps.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from navlog.analysis.metrics import planar_ate, planar_relative_error
from navlog.replay.session import run_replay
from tests.replay.mapping.planar_logs import planar_tum

pytestmark = pytest.mark.slow


# name, ATE bound (m), relative error over 1 m bound (m), the odometry's relative error over 1 m,
# loops at least; measured (bench_slam_datasets.py): seattle ATE 0.053 m, RE 1 m 0.0243 m, 27 loops;
# aces (big loops, long corridors) ATE 0.090 m, RE 1 m 0.045 m, 23 loops
CASES = [("seattle", 0.07, 0.0245, 0.0250, 12), ("aces", 0.12, 0.055, 0.090, 10)]


@pytest.mark.parametrize(("name", "max_ate", "max_re1", "odometry_re1", "min_loops"), CASES)
def test_slam_on_a_real_building_beats_its_odometry(
    shared_dir, tmp_path, name, max_ate, max_re1, odometry_re1, min_loops
):
    carmen = shared_dir / "external-data" / "carmen"
    if not (carmen / name).is_dir():
        pytest.skip(f"{carmen / name}: not in the external data")
    run_replay(carmen / name, "mapping", tmp_path, overrides=["pose_source=slam", "lidar_mapper=off"], progress=False)
    ref_t, ref = planar_tum(carmen / f"{name}.reference.tum")
    est_t, est = planar_tum(tmp_path / "trajectory.tum")
    assert np.array_equal(est_t, ref_t)  # every scan placed
    ate = planar_ate(est, ref)
    re1 = planar_relative_error(est, ref, 1.0)
    assert ate < max_ate, f"ATE {ate:.4f} m"
    assert re1 < max_re1 < odometry_re1, f"relative error over 1 m {re1:.4f} m"  # never worse than odometry
    graph = json.loads((tmp_path / "pose_graph.json").read_text())
    loops = [e for e in graph["edges"] if e["kind"] == "loop"]
    assert len(loops) >= min_loops
    # each loop edge says what found it, and the counts agree
    closed_by = [e["closed_by"] for e in loops]
    assert closed_by.count("buffer") == graph["counts"]["loops_buffer"]
    assert closed_by.count("global") == graph["counts"]["loops_global"]
    assert set(closed_by) <= {"scan", "buffer", "global"} and closed_by.count("scan") >= 1
