"""The mapping targets on the real mapping tour (indoor_room + go2 + mapping, seed 7).

- 2D map from ground-truth poses: occupied precision and recall (of the observable reference
  surfaces) >= 0.95 at 5 cm against the world's map at the scan plane;
- from the drifting /odom: the metrics show the damage;
- from the 3D mapper's poses: F1 within 0.02 of the ground-truth-pose F1;
- 3D mapper: ATE RMSE <= 3 cm; >= 95 % of PCD points within 5 cm of the true surfaces.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.analysis.metrics.report import MetricsOptions, compute_metrics
from navlog.recorder.robot import load_robot
from navlog.recorder.world import load_world, occupancy, write_mesh
from navlog.replay.io.map_server import save_map
from navlog.replay.session import run_replay

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def references(tmp_path_factory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("reference")
    go2 = load_robot("go2")
    height = go2.body.height + go2.scan.mount[2]
    world = load_world("indoor_room")
    yaml_path, _ = save_map(occupancy(world, 0.05, 0.0, height, height), out / "scan_plane.yaml")
    return yaml_path, write_mesh(world, out / "world.ply")


def replay_metrics(log: Path, out: Path, refs, overrides: list[str]) -> dict:
    res = run_replay(log, "mapping", out, overrides=overrides, progress=False)
    return compute_metrics(log, res.out_dir, reference_map=refs[0], reference_mesh=refs[1], options=MetricsOptions())


def test_mapping_targets(mapping_log, references, tmp_path):
    gt = replay_metrics(mapping_log, tmp_path / "gt", references, ["lidar_mapper=off", "pose_source=ground_truth"])
    odom = replay_metrics(mapping_log, tmp_path / "odom", references, ["lidar_mapper=off", "pose_source=odom"])
    lio = replay_metrics(mapping_log, tmp_path / "lio", references, ["pose_source=lidar_mapper"])

    g = gt["map_2d"]
    assert g["precision"] >= 0.95 and g["recall_observable"] >= 0.95
    assert g["coverage"] >= 0.95

    o = odom["map_2d"]
    assert o["precision"] < 0.6 and o["f1_observable"] < g["f1_observable"] - 0.3
    assert odom["trajectory"]["ate"]["translation_m"]["rmse"] > 0.1

    assert abs(lio["map_2d"]["f1_observable"] - g["f1_observable"]) <= 0.02
    assert lio["trajectory"]["ate"]["translation_m"]["rmse"] <= 0.03
    assert lio["trajectory"]["estimate_poses"] >= 1300  # every sweep registered (10 Hz over 138 s)
    assert lio["map_3d"]["accuracy"]["0.05"] >= 0.95
