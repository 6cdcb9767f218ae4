"""navlog check: is a log fit to replay? Real numbers from a recorded log, a defective log, a cut file, real bags."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from navlog.analysis.check import CheckOptions, Status, check_log, format_check, parse_frames, parse_rates
from navlog.analysis.check.tf_coverage import chain_coverage, covered, intersect
from navlog.cli import main
from navlog.errors import ConfigError, LogError
from navlog.replay import messages as m
from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from tests.analysis.sample_nav_log import imu, laser_scan, write_sample_log

S = 1_000_000_000
TELEOP_RATES = {"/scan": 10.0, "/imu/data": 200.0, "/odom": 50.0, "/clock": 100.0}


def by(result, name: str, subject: str):
    found = [c for c in result.checks if c.name == name and c.subject == subject]
    assert len(found) == 1, (name, subject, [(c.name, c.subject) for c in result.checks])
    return found[0]


def figures(result, topic: str):
    return next(t for t in result.topics if t.topic == topic)


def write_defective_log(path: Path) -> Path:
    """10 s: /scan at 10 Hz with no scan between 4 s and 6 s and 3 NaN ranges in its 5th scan; /imu/data
    at 50 Hz whose stamps at messages 100 and 300 are 0.5 s early (two steps back); /odom at 50 Hz with
    message 200 written 1 s early in log time; /tf odom->base_footprint at 50 Hz; no /tf_static."""
    with McapLogWriter(path) as w:
        for i in range(501):
            t = i * S // 50
            imu_stamp = t - S // 2 if i in (100, 300) else t
            msg = imu(t)
            msg.header.stamp = m.stamp(imu_stamp)
            w.write_raw("/imu/data", m.IMU, t, m.serialize(msg, m.IMU))
            odom_t = t - S if i == 200 else t
            odom = m.odometry(t, "odom", "base_footprint", (0.01 * i, 0, 0), (0, 0, 0, 1), (0.5, 0, 0), (0, 0, 0))
            w.write_raw("/odom", m.ODOMETRY, odom_t, m.serialize(odom, m.ODOMETRY))
            tf = m.tf_message([m.transform_stamped(t, "odom", "base_footprint", (0.01 * i, 0, 0), (0, 0, 0, 1))])
            w.write_raw("/tf", m.TF_MESSAGE, t, m.serialize(tf, m.TF_MESSAGE))
            if i % 5 == 0 and i > 0 and not 4 * S < t < 6 * S:
                scan = laser_scan(t, 0.0, 90)
                if i == 25:
                    scan.ranges[:3] = np.nan
                w.write_raw("/scan", m.LASER_SCAN, t, m.serialize(scan, m.LASER_SCAN))
    return path


@pytest.fixture(scope="module")
def defective(tmp_path_factory) -> Path:
    return write_defective_log(tmp_path_factory.mktemp("check") / "defective.mcap")


@pytest.fixture(scope="module")
def sample(tmp_path_factory) -> Path:
    return write_sample_log(tmp_path_factory.mktemp("check") / "sample.mcap", seconds=3.0)


# ------------------------------------------------------------------ a recorded log


@pytest.mark.slow
def test_a_recorded_teleop_log_passes_with_its_rates_measured(teleop_log):
    result = check_log(teleop_log, rates=TELEOP_RATES, frames=[("map", "base_link"), ("odom", "base_footprint")])
    assert result.failed == [], format_check(result)
    assert result.order == "file"
    assert 16.9 < (result.end_ns - result.start_ns) / S <= 17.0
    for topic, hz in TELEOP_RATES.items():
        rate = by(result, "rate", topic)
        assert rate.status is Status.PASS
        assert rate.numbers["expected_hz"] == hz
        assert abs(figures(result, topic).rate_hz - hz) < 0.01 * hz, (topic, figures(result, topic))
        assert abs(figures(result, topic).median_rate_hz - hz) < 0.01 * hz
        assert figures(result, topic).max_gap_s == pytest.approx(1 / hz, abs=2e-3)
        assert by(result, "gaps", topic).status is Status.PASS
        assert by(result, "stamps", topic).numbers["log_time_backward"] == 0
    assert figures(result, "/scan").count == pytest.approx(170, abs=1)
    assert by(result, "stamps", "/scan").numbers["stamp_backward"] == 0
    assert by(result, "scan_values", "/scan").numbers["nan"] == 0
    for chain in ("map->base_link", "odom->base_footprint"):
        tf = by(result, "tf", chain)
        assert tf.status is Status.PASS and tf.numbers["coverage"] >= 0.99, tf.message
    assert by(result, "tf", "map->base_link").numbers["chain"].split()[0] == "map->odom"
    # the same log gives the same bytes
    again = check_log(teleop_log, rates=TELEOP_RATES, frames=[("map", "base_link"), ("odom", "base_footprint")])
    assert again.to_json() == result.to_json()


@pytest.mark.slow
def test_a_truncated_log_is_reported_with_its_readable_span(teleop_log, tmp_path):
    data = teleop_log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    result = check_log(cut)
    integrity = by(result, "integrity", str(cut))
    assert integrity.status is Status.FAIL
    assert integrity.numbers["truncated"] == 1
    readable = integrity.numbers["readable_s"]
    assert 2.0 < readable < 15.0, readable  # about half of the 17 s
    assert integrity.numbers["readable_end_ns"] - integrity.numbers["readable_start_ns"] == round(readable * S)
    assert f"{readable:.3f} s" in integrity.message and "navlog recover" in integrity.message
    assert integrity.numbers["messages_read"] == result.messages > 0
    assert main(["check", str(cut)]) == 1


# ------------------------------------------------------------------ a defective log


def test_backward_stamps_a_gap_and_nan_ranges_are_named(defective):
    result = check_log(defective)
    assert result.status is Status.FAIL

    gap = by(result, "gaps", "/scan")
    assert gap.status is Status.FAIL
    assert gap.numbers["max_gap_s"] == 2.0 and gap.numbers["max_gap_after_index"] == 39
    assert gap.numbers["max_gap_start_s"] == 4.0 and gap.numbers["gaps_over_factor"] == 1
    assert "/scan" in gap.message and "2.000 s after message 39" in gap.message and "20x" in gap.message
    assert figures(result, "/scan").count == 81

    imu = by(result, "stamps", "/imu/data")
    # no pipeline reads /imu/data from this log (a 2D log: the LiDAR mapper is off): a warning
    assert imu.status is Status.WARN and "no replay pipeline reads this topic: a warning" in imu.message
    assert imu.numbers["stamp_backward"] == 2 and imu.numbers["stamp_first_index"] == 100
    assert imu.numbers["stamp_before_ns"] == 99 * S // 50 and imu.numbers["stamp_after_ns"] == 2 * S - S // 2
    assert imu.numbers["log_time_backward"] == 0
    assert "/imu/data" in imu.message and "step back 2 time(s), first at message 100" in imu.message

    odom = by(result, "stamps", "/odom")
    assert odom.status is Status.FAIL
    assert odom.numbers["log_time_backward"] == 1 and odom.numbers["log_time_first_index"] == 200
    assert "t=3.000 s after t=3.980 s" in odom.message
    assert figures(result, "/odom").log_time_backward == 1

    nan = by(result, "scan_values", "/scan")
    assert nan.status is Status.WARN and nan.numbers["nan"] == 3 and nan.numbers["scans"] == 81

    rate = by(result, "rate", "/scan")  # 81 scans over 9.9 s against a 10 Hz median
    assert rate.status is Status.WARN and rate.numbers["rate_hz"] == pytest.approx(80 / 9.9, rel=1e-6)
    assert by(result, "rate", "/imu/data").status is Status.PASS


def test_a_backward_stamp_on_a_topic_no_pipeline_reads_is_a_warning(tmp_path, capsys):
    """A log every pipeline can replay, with one backward stamp on /diagnostics, which none reads."""
    path = write_sample_log(tmp_path / "ok.mcap", seconds=3.0)
    with McapLogWriter(tmp_path / "extra.mcap") as w, open_log(path) as r:
        for env in r.messages():
            w.write(env)
        for i in range(30):
            t = r.start_ns + i * S // 10
            msg = imu(t)
            msg.header.stamp = m.stamp(t - S if i == 12 else t)
            w.write_raw("/diagnostics_imu", m.IMU, t, m.serialize(msg, m.IMU))
    result = check_log(tmp_path / "extra.mcap")
    stamps = by(result, "stamps", "/diagnostics_imu")
    assert stamps.status is Status.WARN and stamps.numbers["stamp_first_index"] == 12
    assert "no replay pipeline reads this topic" in stamps.message
    assert result.status is not Status.FAIL
    assert main(["check", str(tmp_path / "extra.mcap")]) == 0
    # the same backward stamp on a topic the mapper reads fails the log
    with McapLogWriter(tmp_path / "bad.mcap") as w, open_log(path) as r:
        for i, env in enumerate(r.messages()):
            w.write(env)
        for i in range(30):
            t = r.start_ns + i * S // 10
            odom = m.odometry(t - S if i == 12 else t, "odom", "x", (0, 0, 0), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))
            w.write_raw("/odom", m.ODOMETRY, t, m.serialize(odom, m.ODOMETRY))
    assert by(check_log(tmp_path / "bad.mcap"), "stamps", "/odom").status is Status.FAIL


def test_an_expected_rate_fails_when_missed_and_a_failure_elsewhere_only_warns(defective):
    result = check_log(defective, rates={"/scan": 10.0})
    rate = by(result, "rate", "/scan")
    assert rate.status is Status.FAIL and rate.numbers["deviation"] == pytest.approx(80 / 9.9 / 10 - 1, rel=1e-6)
    assert "19% below expected 10.00 Hz" in rate.message
    assert by(result, "gaps", "/scan").status is Status.FAIL  # /scan is required by its rate
    # /imu/data and /odom were not asked for: their backward stamps are warnings
    for topic in ("/imu/data", "/odom"):
        stamps = by(result, "stamps", topic)
        assert stamps.status is Status.WARN and "not a required topic" in stamps.message


def test_a_missing_topic_with_a_near_name_fails_with_did_you_mean(defective):
    result = check_log(defective, require=["/scna", "/imu/data"])
    missing = by(result, "required", "/scna")
    assert missing.status is Status.FAIL and "did you mean '/scan'?" in missing.message
    assert by(result, "required", "/imu/data").numbers["count"] == 501
    far = by(check_log(defective, require=["/livox/lidar"]), "required", "/livox/lidar")
    assert far.status is Status.FAIL and "the log has /imu/data, /odom, /scan, /tf" in far.message


def test_a_pipeline_names_the_topics_it_needs(defective, sample):
    # mapping on a log with /odom/ground_truth reads /scan and /odom/ground_truth
    ok = check_log(sample, pipeline="mapping")
    assert [c.subject for c in ok.checks if c.name == "required"] == ["/scan", "/odom/ground_truth", "/livox/lidar"]
    assert all(c.status is Status.PASS for c in ok.checks if c.name == "required")
    # without ground truth it takes its poses from TF: only /scan is required
    bad = check_log(defective, pipeline="mapping")
    assert [c.subject for c in bad.checks if c.name == "required"] == ["/scan"]
    with pytest.raises(ConfigError, match="did you mean 'mapping'"):
        check_log(defective, pipeline="maping")


# ------------------------------------------------------------------ TF


def test_tf_chains_covered_and_uncovered(defective, sample):
    with_static = check_log(sample, frames=[("map", "base_link"), ("/map", "front_laser")])
    for chain in ("map->base_link", "/map->front_laser"):
        tf = by(with_static, "tf", chain)
        assert tf.status is Status.PASS and tf.numbers["coverage"] == 1.0
    assert by(with_static, "tf", "map->base_link").numbers["chain"] == (
        "map->odom odom->base_footprint base_footprint->base_link"
    )
    # no /tf_static: map does not exist, base_link is not connected to odom
    without = check_log(defective, frames=[("map", "base_link"), ("odom", "base_link"), ("odom", "base_footprint")])
    missing = by(without, "tf", "map->base_link")
    assert missing.status is Status.FAIL and missing.numbers["coverage"] == 0.0
    assert "frame 'map' is in neither /tf nor /tf_static" in missing.message
    assert by(without, "tf", "odom->base_link").status is Status.FAIL
    odom = by(without, "tf", "odom->base_footprint")
    assert odom.status is Status.PASS and odom.numbers["coverage"] == 1.0


def test_tf_coverage_of_a_chain_with_a_hole():
    assert covered([0, S, 2 * S, 5 * S, 6 * S], S) == [(0, 2 * S), (5 * S, 6 * S)]
    assert intersect([(0, 4), (6, 10)], [(2, 7), (9, 12)]) == [(2, 4), (6, 7), (9, 10)]
    dynamic = [i * S // 10 for i in range(101) if not 30 <= i <= 60]  # 0..10 s at 10 Hz, nothing from 3.0 to 6.0 s
    edges = {("map", "odom"): (True, [0]), ("odom", "base_link"): (False, dynamic)}
    cov = chain_coverage(edges, "map", "base_link", (0, 10 * S), S)
    assert cov.chain == ["map->odom", "odom->base_link"]
    assert cov.coverage == pytest.approx(0.68) and cov.covered_ns == 68 * S // 10
    assert cov.largest_hole == (29 * S // 10, 61 * S // 10)
    # with the 3.2 s hole tolerated, the chain covers the whole span
    assert chain_coverage(edges, "map", "base_link", (0, 10 * S), 4 * S).coverage == 1.0
    assert chain_coverage(edges, "base_link", "map", (0, 10 * S), S).chain == ["odom->base_link", "map->odom"]


# ------------------------------------------------------------------ real bags


@pytest.mark.parametrize(
    ("bag", "counts"),
    [
        ("neato_drive_square", {"/scan": 185, "/odom": 194, "/tf": 585, "/stable_scan": 186}),
        ("tb3_gazebo_walker", {"/imu": 3869, "/scan": 102, "/odom": 599, "/clock": 261}),
        ("rosbag2_talker_mcap", {"/topic": 10, "/rosout": 10}),
        ("rosbag2_wbag_split_mcap", {"AAA": 804, "HHH": 726}),
    ],
)
def test_real_bags_are_checked(bags_dir, bag, counts):
    result = check_log(bags_dir / bag)
    assert by(result, "integrity", str(bags_dir / bag)).status is Status.PASS
    for topic, n in counts.items():
        assert figures(result, topic).count == n
    assert json.loads(result.to_json())["messages"] == result.messages


def test_real_bags_tf_over_a_simulation_clock(bags_dir):
    # tb3: header stamps run on Gazebo's clock, log times on the wall clock
    result = check_log(bags_dir / "tb3_gazebo_walker", frames=[("odom", "base_scan")], require=["/scan"])
    tf = by(result, "tf", "odom->base_scan")
    assert tf.status is Status.PASS and tf.numbers["coverage"] > 0.99
    assert tf.numbers["span_end_ns"] - tf.numbers["span_start_ns"] < 30 * S
    assert tf.numbers["chain"] == "odom->base_footprint base_footprint->base_link base_link->base_scan"
    neato = check_log(bags_dir / "neato_drive_square")
    assert by(neato, "types", str(bags_dir / "neato_drive_square")).numbers["unknown"] == 2
    stable = by(neato, "stamps", "/stable_scan")  # a real defect of this bag: one stamp 6 ms back
    # on a topic no pipeline reads (they read /scan): a warning, and the bag replays fine
    assert stable.status is Status.WARN and stable.numbers["stamp_first_index"] == 183
    assert stable.numbers["stamp_before_ns"] - stable.numbers["stamp_after_ns"] == pytest.approx(6e6, abs=1e6)
    assert neato.status is not Status.FAIL
    # read in place of /scan (--remap /scan=/stable_scan), it fails
    assert by(
        check_log(bags_dir / "neato_drive_square", require=["/stable_scan"]), "stamps", "/stable_scan"
    ).status is (Status.FAIL)
    assert math.isclose(figures(neato, "/scan").rate_hz, 4.49, abs_tol=0.01)


# ------------------------------------------------------------------ the command


def test_the_command_exit_status_table_and_json(defective, sample, tmp_path, capsys):
    assert main(["check", str(sample), "--frames", "map:base_link", "--rate", "/scan=10"]) == 0
    text = capsys.readouterr().out
    assert "Result: PASS" in text and "fit to replay" in text
    assert main(["check", str(defective), "--json"]) == 1
    out = capsys.readouterr().out
    data = json.loads(out)
    assert data["status"] == "FAIL" and data["counts"]["FAIL"] == len(
        [c for c in data["checks"] if c["status"] == "FAIL"]
    )
    assert main(["check", str(defective), "--json"]) == 1
    assert capsys.readouterr().out == out  # same bytes
    assert main(["check", str(tmp_path / "nothing.mcap")]) == 2
    assert "nothing.mcap: no such file" in capsys.readouterr().err
    assert main(["check", str(sample), "--frames", "map-base_link"]) == 2
    assert "expected TARGET:SOURCE" in capsys.readouterr().err


def test_parsing_frames_and_rates():
    assert parse_frames(["map:base_link", " odom : base_footprint"]) == [
        ("map", "base_link"),
        ("odom", "base_footprint"),
    ]
    assert parse_rates(["/scan=10", "/imu/data=200.5"]) == {"/scan": 10.0, "/imu/data": 200.5}
    for bad in ("map", "map:", ":base_link", "a:b:c"):
        with pytest.raises(ConfigError, match="TARGET:SOURCE"):
            parse_frames([bad])
    for bad in ("/scan", "/scan=fast", "/scan=0", "=10"):
        with pytest.raises(ConfigError, match="TOPIC=HZ"):
            parse_rates([bad])
    with pytest.raises(LogError):
        check_log("/no/such/log.mcap")
    assert CheckOptions().gap_factor == 5.0


def test_the_package_is_light_and_states_its_api():
    import subprocess
    import sys

    import navlog.analysis
    import navlog.analysis.check as check

    code = "import sys, navlog.analysis.check; print(sorted(m for m in ('numpy', 'rich', 'mcap') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    assert check.__doc__ and all(getattr(check, n) is not None for n in check.__all__)
    assert navlog.analysis.check_log is check.check_log


def test_a_log_span_past_int64_is_a_gap_not_an_overflow():
    # another topic's log time at the end of uint64 (a far-future stamp): the tail gap is measured in Python
    # integers (an int64 subtraction overflowed)
    from array import array

    from navlog.analysis.check.checks import gaps
    from navlog.analysis.check.collect import TopicSeries

    series = TopicSeries("/scan", "sensor_msgs/msg/LaserScan", True, array("q", [1_000_000_000, 2_000_000_000]))
    check = gaps(series, (0, 2**64 - 1), CheckOptions())
    assert check.numbers["tail_s"] == pytest.approx((2**64 - 1 - 2_000_000_000) / 1e9)
    assert check.status != Status.PASS


def test_a_topic_several_publishers_write_at_one_instant_is_timed_by_its_instants():
    """/tf of a simulator: the odometry, localisation and wheel transforms of one step logged at one instant,
    every 35 ms. Its rate is its instants' (28.57 Hz, as the step is) and it has no gaps; before, most periods
    were 0, and the check warned that its log times do not advance and counted every step a gap. A topic whose
    every message is logged at one instant still gets that warning."""
    from array import array

    from navlog.analysis.check.checks import gaps, rate
    from navlog.analysis.check.collect import TopicSeries

    steps = [k * 35_000_000 for k in range(200)]
    tf = TopicSeries("/tf", m.TF_MESSAGE, False, array("q", sorted(steps * 3)))
    r, g = rate(tf, None, CheckOptions()), gaps(tf, (0, steps[-1]), CheckOptions())
    assert r.status == Status.PASS and r.numbers["rate_hz"] == pytest.approx(1e9 / 35e6)
    assert g.status == Status.PASS and g.numbers["gaps_over_factor"] == 0
    stuck = TopicSeries("/tf", m.TF_MESSAGE, False, array("q", [5_000_000] * 10))
    assert "log times do not advance" in rate(stuck, None, CheckOptions()).message
    # the largest gap is named by its last message before it: the 3 messages of step 99 end at message 299
    late = TopicSeries(
        "/tf", m.TF_MESSAGE, False, array("q", sorted(steps[:100] * 3 + [s + 1_000_000_000 for s in steps[100:]] * 3))
    )
    g = gaps(late, (0, steps[-1] + 1_000_000_000), CheckOptions())
    assert g.numbers["max_gap_after_index"] == 299 and g.numbers["max_gap_start_s"] == pytest.approx(99 * 0.035)
    # a stamped topic whose messages are each written twice (same log time, same stamp) is not timed as fine
    scans = [k * 100_000_000 for k in range(50)]
    twice = TopicSeries("/scan", m.LASER_SCAN, True, array("q", sorted(scans * 2)), array("q", sorted(scans * 2)))
    r = rate(twice, None, CheckOptions())
    assert (
        r.status == Status.WARN and r.numbers["repeated"] == 50 and "repeat another's log time and header" in r.message
    )
