"""The mapping pipeline on a real robot's bag (the Neato: 361 beams, about 65 % of them inf)."""

from __future__ import annotations

import json

from navlog.replay.io.map_server import load_map
from navlog.replay.session import run_replay

NO_RETURN = (
    "/scan: ranges with no return (inf or >= range_max; not used: "
    "set occupancy.grid.no_return_ray_length to clear along them)"
)


def test_inf_beams_of_a_real_bag_neither_clear_walls_nor_pass_unreported(bags_dir, tmp_path):
    bag = bags_dir / "neato_drive_square"
    tf = "pose_source=tf"  # the TF mapper's rules (auto picks SLAM on a log without ground truth)
    run_replay(bag, "mapping", tmp_path / "new", overrides=[tf], progress=False)
    # the old rule: every no-return beam clears up to range_max (5 m)
    run_replay(
        bag, "mapping", tmp_path / "old", overrides=[tf, "occupancy.grid.no_return_ray_length=5.0"], progress=False
    )
    manifest = json.loads((tmp_path / "new" / "manifest.json").read_text())
    assert manifest["skipped"][NO_RETURN] > 10_000
    assert NO_RETURN not in json.loads((tmp_path / "old" / "manifest.json").read_text())["skipped"]
    new, old = load_map(tmp_path / "new" / "map.yaml"), load_map(tmp_path / "old" / "map.yaml")
    # clearing along inf beams erases the walls the returns marked, and floods the outside
    assert (new.data == 100).sum() > 3 * (old.data == 100).sum()
    assert (old.data == 0).sum() > 3 * (new.data == 0).sum()


def test_the_manifest_records_the_pose_source_used(bags_dir, tmp_path):
    # the bag has no ground truth: auto picks SLAM (scans + odometry TF), and the manifest says so
    run_replay(bags_dir / "neato_drive_square", "mapping", tmp_path / "out", progress=False)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["parameters"]["pose_source"] == "auto"  # what was asked for
    assert manifest["pipeline_info"]["pose_source"] == "slam"  # what the mapper ran with
