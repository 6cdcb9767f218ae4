"""The SLAM node end to end: a short go2 recording without a localiser, replayed with pose_source=slam."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from navlog.analysis.metrics import compute_metrics
from navlog.errors import NavlogError
from navlog.replay.io import open_log
from navlog.replay.io.map_server import load_map
from navlog.replay.session import run_replay

ODOM_PARENTS_FROM_LOG = "/tf: transforms into 'odom' from the log (ignored: SLAM publishes its own)"


@pytest.fixture(scope="module")
def unlocalised_log(tmp_path_factory):
    """The 17 s teleop drive, recorded as a real robot's log: no map -> odom on /tf."""
    from navlog.recorder.record import prepare, record

    out = tmp_path_factory.mktemp("slam") / "teleop_none.mcap"
    record(prepare("indoor_room", "go2", "teleop", seed=3, localization="none"), out, progress=False)
    return out


def tf_children(log) -> set[str]:
    with open_log(log) as reader:
        return {ts.child_frame_id for env in reader.messages(["/tf"]) for ts in env.msg.transforms}


def test_localization_none_records_no_map_to_odom_but_keeps_ground_truth(unlocalised_log, teleop_log):
    assert "odom" not in tf_children(unlocalised_log)  # odom -> base_footprint -> base_link only
    assert "odom" in tf_children(teleop_log)  # the default keeps the perfect localiser's map -> odom
    with open_log(unlocalised_log) as reader:
        assert "/odom/ground_truth" in reader.topics
        assert reader.metadata["navlog"]["localization"] == "none"


def test_slam_maps_the_unlocalised_log_within_centimetres(unlocalised_log, tmp_path):
    res = run_replay(
        unlocalised_log,
        "mapping",
        tmp_path / "slam",
        overrides=["pose_source=slam", "lidar_mapper=off"],
        progress=False,
    )
    assert res.manifest["pipeline_info"]["pose_source"] == "slam"
    graph = json.loads((tmp_path / "slam" / "pose_graph.json").read_text())
    assert len(graph["nodes"]) >= 5 and {e["kind"] for e in graph["edges"]} == {"match"}
    c = graph["counts"]  # the run's summary row says what the pose graph holds
    assert res.manifest["pipeline_info"]["slam"] == (
        f"{len(graph['nodes'])} keyframes of {c['scans']} scans ({len(graph['nodes']) - 1} matched, 0 by odometry"
        f" alone); 0 loops closed in {c['loop_attempts']} searches (0 ambiguous, 0 taken back, 0 global,"
        f" 0 by the running buffer); {c['optimizations']} optimisations"
    )
    slam = compute_metrics(unlocalised_log, tmp_path / "slam")["trajectory"]["ate"]["translation_m"]
    run_replay(
        unlocalised_log,
        "mapping",
        tmp_path / "odom",
        overrides=["pose_source=odom", "lidar_mapper=off"],
        progress=False,
    )
    odom = compute_metrics(unlocalised_log, tmp_path / "odom")["trajectory"]["ate"]["translation_m"]
    assert slam["rmse"] < 0.03 and slam["rmse"] < odom["rmse"]
    assert slam["count"] > 150  # a pose at every scan, not only at keyframes
    m = load_map(tmp_path / "slam" / "map.yaml")
    assert (m.data == 100).sum() > 300 and (m.data == 0).sum() > 5000
    # the same log replayed again: the same bytes
    again = run_replay(
        unlocalised_log,
        "mapping",
        tmp_path / "again",
        overrides=["pose_source=slam", "lidar_mapper=off"],
        progress=False,
    )
    assert {"map_pgm", "trajectory_tum", "pose_graph", "replay_mcap"} <= set(res.manifest["outputs"])
    for name, out in res.manifest["outputs"].items():
        assert again.manifest["outputs"][name]["sha256"] == out["sha256"], name


def recorded_transforms(out) -> list[tuple[str, str]]:
    """(parent, child) of every transform on /tf in a replay's replay.mcap."""
    with open_log(out / "replay.mcap") as reader:
        return [
            (ts.header.frame_id, ts.child_frame_id) for env in reader.messages(["/tf"]) for ts in env.msg.transforms
        ]


def placed_scans(out) -> int:
    """The scans a SLAM replay placed: the poses of its trajectory.tum."""
    return sum(not line.startswith("#") for line in (out / "trajectory.tum").read_text().splitlines())


def test_a_logged_map_to_odom_is_ignored_and_counted(teleop_log, tmp_path, capsys):
    from navlog.cli import main
    from tests.analysis.view.rrd import column, read_rrd

    res = run_replay(
        teleop_log, "mapping", tmp_path / "out", overrides=["pose_source=slam", "lidar_mapper=off"], progress=False
    )
    logged = res.manifest["skipped"][ODOM_PARENTS_FROM_LOG]
    assert logged > 100
    assert compute_metrics(teleop_log, tmp_path / "out")["trajectory"]["ate"]["translation_m"]["rmse"] < 0.03
    # replay.mcap's /tf holds the SLAM's map -> odom, one for every scan placed, and none of the log's transforms
    placed = placed_scans(tmp_path / "out")
    assert recorded_transforms(tmp_path / "out") == [("map", "odom")] * placed
    # viewed with the replay, the log's map -> odom (the perfect localiser's) gives way to the SLAM's
    rrd = tmp_path / "v.rrd"
    capsys.readouterr()
    assert main(["view", str(teleop_log), "--replay", str(tmp_path / "out"), "--save", str(rrd), "--json"]) == 0
    skipped = json.loads(capsys.readouterr().out)["skipped"]
    assert skipped["/tf: transforms into odom (the replay's own drawn instead)"] == logged
    rows = column(read_rrd(rrd), "/tf/odom", "Transform3D:translation")
    assert placed <= len(rows) <= placed + 1  # the SLAM's, the first held from the log's start


def test_the_view_of_a_slam_replay_places_the_map_by_the_slam_s_map_to_odom(unlocalised_log, tmp_path, capsys):
    from navlog.cli import main

    out = tmp_path / "slam"
    run_replay(unlocalised_log, "mapping", out, overrides=["pose_source=slam", "lidar_mapper=off"], progress=False)
    assert len(recorded_transforms(out)) == placed_scans(out)
    capsys.readouterr()
    assert main(["view", str(unlocalised_log), "--replay", str(out), "--save", str(tmp_path / "v.rrd")]) == 0
    err = capsys.readouterr()
    # the log has no map frame of its own: the replay's map -> odom links the map to the robot's odometry
    assert "in frame map" in err.out + err.err
    assert "without a TF path" not in err.out + err.err


def test_odometry_jumps_missed_reversals_and_unplaced_stretches_are_named_in_the_skipped_inputs():
    from navlog.replay.nodes.slam import SlamNode, SlamNodeParams

    node = SlamNode(SlamNodeParams())
    c = node.slam.counts
    c.odometry_jumps.extend([(5_000_000_000, 3.99, 0.02, 0.96), (6_000_000_000, 0.55, -1.40, 0.95)])
    c.unplaced.extend([(8, 10, 12_500_000_000, 14_000_000_000)] + [(20 + 2 * k, 20 + 2 * k, 0, 0) for k in range(6)])
    c.reversals_missed.extend([(7_000_000_000, 0.09, -0.06), (7_500_000_000, 0.04, -0.21)])
    c.reversals_inferred.extend([(7_000_000_000, -1), (9_000_000_000, 1), (9_500_000_000, -1)])
    skipped = node.skipped_counts()
    assert (
        skipped[
            "/scan: odometry jumped (scan matched up to 3.99 m and 80 deg from its prediction by the wider search; see"
            " pose_graph.json odometry_jumps)"
        ]
        == 2
    )
    key = "/scan: keyframes 8-10 (stamps 12.500-14.000 s) placed by odometry alone: their scans matched nothing before them"
    assert skipped[key] == 3
    # five stretches are named, the rest summed
    assert skipped["/scan: keyframes placed by odometry alone in 2 more stretches (see pose_graph.json unplaced)"] == 2
    key = (
        "/scan: steps the odometry measured forward and the scans back (up to 0.21 m; does the odometry report"
        " driving backwards? see pose_graph.json reversals_missed)"
    )
    assert skipped[key] == 2
    assert node.summary().endswith(
        "; 2 odometry jumps placed by the wider search; 7 stretches not placed; 2 steps back the odometry measured"
        " forward; the odometry read backwards 2 times where the scans said the robot drove back"
    )
    graph = node.pose_graph()
    assert graph["counts"]["odometry_jumps"] == 2 and len(graph["unplaced"]) == 7
    assert graph["counts"]["reversals_missed"] == 2 and graph["counts"]["reversals_inferred"] == 3
    assert graph["reversals_inferred"][:2] == [
        {"stamp_ns": 7_000_000_000, "read": "backwards"},
        {"stamp_ns": 9_000_000_000, "read": "forwards"},
    ]
    assert graph["reversals_missed"][1] == {"stamp_ns": 7_500_000_000, "odometry_forward": 0.04, "scans_back": -0.21}
    assert graph["odometry_jumps"][1] == {"stamp_ns": 6_000_000_000, "distance": 0.55, "turn": -1.40, "response": 0.95}
    assert graph["unplaced"][0] == {
        "first": 8,
        "last": 10,
        "first_stamp_ns": 12_500_000_000,
        "last_stamp_ns": 14_000_000_000,
    }


def test_a_laser_mount_not_finite_or_far_off_is_a_named_skip():
    import types

    from navlog.replay.nodes.slam import SlamNode, SlamNodeParams

    node = SlamNode(SlamNodeParams())
    node.publish = lambda *a, **k: None  # type: ignore[method-assign]
    n = 360
    msg = types.SimpleNamespace(
        header=types.SimpleNamespace(frame_id="laser"),
        angle_min=-math.pi,
        angle_max=math.pi - 2 * math.pi / n,
        angle_increment=2 * math.pi / n,
        ranges=[2.0] * n,
        range_min=0.05,
        range_max=8.0,
    )
    for k, offset in enumerate((math.nan, 25.0)):
        mount = np.eye(4)
        mount[0, 3] = offset
        node._process(msg, k * 600_000_000, np.eye(4), mount, np.eye(4))
    key = (
        "/scan: laser mount (laser in the base frame) not finite or farther than slam.max_laser_range (20 m) from the"
        " base: check /tf_static"
    )
    assert node.skipped_counts() == {key: 2} and node.slam.counts.scans == 0
    mount = np.eye(4)
    mount[0, 3] = 0.1  # a laser 10 cm ahead of the base: taken
    node._process(msg, 2 * 600_000_000, np.eye(4), mount, np.eye(4))
    assert node.skipped_counts() == {key: 2} and node.slam.counts.scans == 1


def test_the_base_frame_is_chosen_below_the_odometry_frame_whatever_arrives_first():
    from navlog.replay.nodes.slam import SlamNode, SlamNodeParams

    node = SlamNode(SlamNodeParams())  # base_frame base_footprint
    node.tf.add("base_link", "laser", 0, (0.1, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0), static=True)  # /tf_static first
    assert node.base == "base_footprint" and node._base is None  # undecided: nothing hangs below odom yet
    node.tf.add("odom", "base_footprint", 1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    node.tf.add("base_footprint", "base_link", 1, (0.0, 0.0, 0.3), (0.0, 0.0, 0.0, 1.0))
    assert node.base == "base_footprint" and node._base == "base_footprint"
    other = SlamNode(SlamNodeParams())  # a robot whose odometry moves base_link
    other.tf.add("odom", "base_link", 1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    assert other.base == "base_link" and other._base == "base_link"


def test_a_log_whose_odometry_frame_is_not_odom_is_mapped_with_slam_odom_frame(shared_dir, tmp_path):
    from navlog.replay.io.formats import open_log
    from navlog.replay.io.logwriter import McapLogWriter
    from navlog.replay.runtime.executor import Envelope

    log, scans = tmp_path / "wheel_odom.mcap", 0
    with open_log(shared_dir / "external-data" / "carmen" / "seattle") as reader, McapLogWriter(log) as writer:
        for env in reader.messages(["/scan", "/odom", "/tf", "/tf_static"]):
            scans += env.topic == "/scan"
            if scans > 40:
                break
            if env.topic == "/tf":
                for ts in env.msg.transforms:
                    ts.header.frame_id = "wheel_odom" if ts.header.frame_id == "odom" else ts.header.frame_id
            elif env.topic == "/odom":
                env.msg.header.frame_id = "wheel_odom"
            writer.write(Envelope(env.topic, env.typename, env.time_ns, env.msg))
    common = ["pose_source=slam", "lidar_mapper=off"]
    with pytest.raises(NavlogError, match="produced nothing"):  # every scan waits for odom -> base
        run_replay(log, "mapping", tmp_path / "default", overrides=common, progress=False)
    res = run_replay(
        log, "mapping", tmp_path / "named", overrides=[*common, "slam.odom_frame=wheel_odom"], progress=False
    )
    lines = (tmp_path / "named" / "trajectory.tum").read_text().splitlines()
    assert len([x for x in lines if not x.startswith("#")]) == 40
    assert res.manifest["skipped"] == {}
    # the node publishes map -> wheel_odom
    from navlog.replay.mapping.slam2d import SlamParams
    from navlog.replay.nodes.slam import SlamNode, SlamNodeParams

    node = SlamNode(SlamNodeParams(slam=SlamParams(odom_frame="wheel_odom")))
    sent: list = []
    node.publish = lambda topic, typename, msg: sent.append(msg)  # type: ignore[method-assign,assignment]
    node._publish_tf(0)
    assert [(t.header.frame_id, t.child_frame_id) for m in sent for t in m.transforms] == [("map", "wheel_odom")]


def test_the_pose_at_every_keyframe_is_published_with_its_covariance_scaled_as_slam_toolbox_does(
    unlocalised_log, tmp_path
):
    def poses(out):
        with open_log(out / "replay.mcap") as reader:
            msgs = [env.msg for env in reader.messages(["/pose"])]
        assert {m.header.frame_id for m in msgs} == {"map"}
        xy = np.array([(m.pose.pose.position.x, m.pose.pose.position.y) for m in msgs])
        return xy, np.array([np.asarray(m.pose.covariance).reshape(6, 6) for m in msgs])

    base = ["pose_source=slam", "lidar_mapper=off"]
    run_replay(unlocalised_log, "mapping", tmp_path / "a", overrides=base, progress=False)
    xy, cov = poses(tmp_path / "a")
    nodes = json.loads((tmp_path / "a" / "pose_graph.json").read_text())["nodes"]
    assert len(xy) == len(nodes) >= 5  # one at every keyframe, where the keyframe was placed
    assert np.abs(xy - np.array([(n["x"], n["y"]) for n in nodes])).max() < 0.01
    assert np.allclose(cov[0], np.diag([1.0, 1.0, 0, 0, 0, 1.0]))  # the first: slam_toolbox's identity
    position = cov[1:, :2, :2]
    assert (np.linalg.eigvalsh(position) > 0).all() and position.max() < 0.01  # matched steps: centimetres
    assert (cov[1:, 5, 5] > 0).all() and (cov[1:, 2:5, :] == 0).all()
    run_replay(
        unlocalised_log,
        "mapping",
        tmp_path / "b",
        overrides=[*base, "slam.position_covariance_scale=4", "slam.yaw_covariance_scale=9"],
        progress=False,
    )
    xy_b, cov_b = poses(tmp_path / "b")
    assert np.array_equal(xy_b, xy)
    assert np.allclose(cov_b[:, :2, :2], 4 * cov[:, :2, :2]) and np.allclose(cov_b[:, 5, 5], 9 * cov[:, 5, 5])
