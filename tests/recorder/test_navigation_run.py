"""Navigation runs recorded end to end: Nav2 drives the Go2 through the article's tour, and a replay of the
log through the same navigation pipeline regenerates its plans and commands bit for bit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navlog.analysis.metrics.report import compute_metrics
from navlog.cli import main
from navlog.errors import ConfigError
from navlog.recorder.navigation import navigation_pipeline
from navlog.recorder.record import prepare, record
from navlog.recorder.world import write_world_map
from navlog.replay.io import open_log
from navlog.replay.session import pipeline_params, run_replay

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
NAV_TOPICS = (
    "/plan",
    "/cmd_vel_nav",
    "/cmd_vel_smoothed",
    "/cmd_vel",
    "/global_costmap/costmap",
    "/local_costmap/costmap",
    "/local_costmap/published_footprint",
    "/goal_pose",
    "/navlog/events",
    "/scan",
    "/odom",
    "/tf",
)


@pytest.fixture(scope="module")
def nav_tour(tmp_path_factory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("nav") / "nav_tour.mcap"
    res = record(prepare(None, None, "nav_tour", seed=2), out, progress=False)
    return out, res


def test_the_go2_reaches_every_waypoint_of_the_tour_without_collision(nav_tour, tmp_path) -> None:
    log, res = nav_tour
    assert res.failed is None, res.failed
    goals = res.navigation["goals"]
    assert [g["name"] for g in goals] == [
        "inner_southwest",
        "inner_southeast",
        "inner_northeast",
        "inner_northwest",
        "initial_pose",
    ]
    assert all(g["status"] == "succeeded" and g["recoveries"] == 0 for g in goals)
    with open_log(log) as r:
        missing = [t for t in NAV_TOPICS if t not in r.topics]
    assert not missing
    ref = write_world_map("indoor_room", tmp_path / "world.yaml", margin=0.0).yaml_path
    nav = compute_metrics(log, reference_map=ref)["navigation"]
    assert nav["goals_succeeded"] == 5 and nav["collisions"] == 0 and nav["recoveries"] == 0
    assert nav["min_clearance_m"] >= 0.25
    assert nav["speed_mps"]["max"] <= 0.35  # CHAMP's limit 0.3 m/s, plus the gait's sway


def test_a_replay_of_the_log_regenerates_its_plans_and_commands_bit_for_bit(nav_tour, tmp_path) -> None:
    log, _ = nav_tour
    params = pipeline_params("navigation", overrides=["goals=indoor_room_waypoints", "seed=2"])
    res = run_replay(log, "navigation", tmp_path / "out", params=params, progress=False)

    def raw(path: Path, topic: str) -> list[tuple[int, bytes]]:
        with open_log(path) as r:
            return [(e.time_ns, e.msg) for e in r.messages([topic], decode=False)]

    for topic, least in (("/plan", 20), ("/cmd_vel_nav", 500), ("/cmd_vel", 500)):
        live, replayed = raw(log, topic), raw(res.out_dir / "replay.mcap", topic)
        assert len(live) >= least, topic
        assert live == replayed, topic
    # every topic the stack regenerates appears once, as often as live: none is also read from the log
    with open_log(log) as live_log, open_log(res.out_dir / "replay.mcap") as replay_log:
        counts = {t: (live_log.topics[t].count, i.count) for t, i in replay_log.topics.items()}
    assert counts["/local_costmap/published_footprint"][0] >= 300
    assert all(live == replayed for live, replayed in counts.values()), counts
    report = json.loads((res.out_dir / "navigation.json").read_text())
    assert report["succeeded"] == 5 and report["failed"] == 0


def test_an_unknown_controller_plugin_is_refused_before_simulating(tmp_path) -> None:
    text = (REPO / "config" / "nav2" / "nav_go2.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("RegulatedPurePursuitController", "RegulatedPurePursuitControler"))
    with pytest.raises(ConfigError, match="RegulatedPurePursuitController"):
        navigation_pipeline(prepare(None, None, "nav_tour").scenario, 0, bad)
    code = main(["-q", "record", "--scenario", "nav_tour", "--params", str(bad), "-o", str(tmp_path / "x.mcap")])
    assert code != 0 and not (tmp_path / "x.mcap").exists()


def test_navigation_runs_on_amcl_in_the_loop(tmp_path) -> None:
    # KiBot in walled_room, one goal 1.8 m away; no perfect localiser: AMCL's map -> odom drives navigation
    (tmp_path / "goals.yaml").write_text("goals:\n  - {name: ahead, x: 1.5, y: -1.0, yaw: 0.0}\n")
    (tmp_path / "amcl_nav.yaml").write_text(
        "name: amcl_nav\nkind: navigate\nworld: walled_room\nrobot: kibot\nnav2_params: nav_kibot\n"
        f"goals: {tmp_path / 'goals.yaml'}\nmap: world\nmap_margin: 0.0\nhold: 0.5\nmax_duration: 40.0\n"
    )
    setup = prepare(None, None, str(tmp_path / "amcl_nav.yaml"), seed=1, localization="amcl")
    res = record(setup, tmp_path / "amcl.mcap", progress=False)
    assert res.failed is None, res.failed
    assert res.topics["/amcl_pose"][1] >= 5
    with open_log(tmp_path / "amcl.mcap") as r:
        parents = {(t.header.frame_id, t.child_frame_id) for e in r.messages(["/tf"]) for t in e.msg.transforms}
    assert ("map", "odom") in parents  # published by AMCL only: the simulator publishes none


def test_a_nav2_file_without_a_controller_is_refused_naming_the_block(tmp_path) -> None:
    safety_only = REPO / "config" / "nav2" / "kibot_safety.yaml"  # costmap, planner and the filters only
    with pytest.raises(ConfigError, match="kibot_safety.yaml: no controller_server block"):
        navigation_pipeline(prepare(None, None, "nav_tour").scenario, 0, safety_only)
