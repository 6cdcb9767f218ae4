"""Recording runs: determinism, the file format, the mapping tour, and every bad input."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import ConfigError, NavlogError
from navlog.recorder.record import expected_duration, format_summary, prepare, record
from navlog.recorder.world import clearance, load_world
from navlog.replay.io import open_log

pytestmark = pytest.mark.slow

NAVLOG = [sys.executable, "-m", "navlog"]
REPO = Path(__file__).resolve().parents[2]


def gt_xy(path: Path) -> np.ndarray:
    with open_log(path) as r:
        return np.array(
            [(e.msg.pose.pose.position.x, e.msg.pose.pose.position.y) for e in r.messages(["/odom/ground_truth"])]
        )


def test_same_seed_is_byte_identical_in_a_fresh_process(teleop_log, tmp_path):
    again = tmp_path / "again.mcap"
    proc = subprocess.run(
        NAVLOG
        + [
            "-q",
            "record",
            "--world",
            "indoor_room",
            "--robot",
            "go2",
            "--scenario",
            "teleop",
            "--seed",
            "3",
            "-o",
            str(again),
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert again.read_bytes() == teleop_log.read_bytes()
    assert "real-time factor" in proc.stdout and "/livox/lidar" in proc.stdout


def test_other_seed_changes_noise_not_world(teleop_log, tmp_path):
    other = tmp_path / "seed4.mcap"
    record(prepare("indoor_room", "go2", "teleop", seed=4), other, progress=False)
    assert other.read_bytes() != teleop_log.read_bytes()
    assert np.array_equal(gt_xy(other), gt_xy(teleop_log))  # same true motion
    with open_log(other) as a, open_log(teleop_log) as b:
        sa = [np.asarray(e.msg.ranges) for e in a.messages(["/scan"])]
        sb = [np.asarray(e.msg.ranges) for e in b.messages(["/scan"])]
    assert len(sa) == len(sb) == 171
    fin = np.isfinite(sa[5]) & np.isfinite(sb[5])
    diff = np.abs(sa[5][fin] - sb[5][fin])
    assert 0.005 < diff.mean() < 0.03  # two draws of sigma 0.01 noise differ by ~0.011 on average


def test_mcap_format_and_metadata(teleop_log):
    from mcap.reader import make_reader

    with open(teleop_log, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        assert {ci.compression for ci in summary.chunk_indexes} == {"zstd"}
        names = {s.name for s in summary.schemas.values()}
        assert "sensor_msgs/msg/PointCloud2" in names and "tf2_msgs/msg/TFMessage" in names
        qos = {c.topic: c.metadata["offered_qos_profiles"] for c in summary.channels.values()}
        assert "durability: 1" in qos["/tf_static"] and "durability: 2" in qos["/scan"]
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        nav = meta["navlog"]
        assert (nav["world"], nav["robot"], nav["scenario"], nav["seed"]) == ("indoor_room", "go2", "teleop", "3")
        assert len(nav["config_hash"]) == 64
        # log_time = publish_time = header.stamp
        for schema, channel, msg in reader.iter_messages(topics=["/scan", "/odom"]):
            assert msg.log_time == msg.publish_time
        from navlog.replay import messages

        for schema, channel, msg in reader.iter_messages(topics=["/scan"]):
            scan = messages.deserialize(msg.data, schema.name)
            assert messages.to_ns(scan.header.stamp) == msg.log_time


def test_opens_with_rosbags_anyreader_and_mcap_ros2_decoder(teleop_log):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    with AnyReader([teleop_log]) as r:
        conns = {c.topic: c for c in r.connections}
        assert conns["/scan"].msgcount == 171
        n = 0
        for conn, t, raw in r.messages(connections=[conns["/odom"]]):
            msg = r.deserialize(raw, conn.msgtype)
            assert msg.header.frame_id == "odom"
            n += 1
        assert n == 851
    with open(teleop_log, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        decoded = list(reader.iter_decoded_messages(topics=["/livox/lidar"]))
        assert len(decoded) == 170
        assert decoded[0].decoded_message.point_step == 22


def test_rerun_converts_the_log(teleop_log, tmp_path):
    rerun = Path(sys.executable).parent / "rerun"
    if not rerun.exists():
        pytest.skip("rerun CLI not installed")
    out = tmp_path / "t.rrd"
    proc = subprocess.run(
        [str(rerun), "mcap", "convert", str(teleop_log), "-o", str(out)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert out.stat().st_size > 1000


def test_mapping_tour_stays_clear_and_returns(mapping_log):
    world = load_world("indoor_room")
    xy = gt_xy(mapping_log)
    with open_log(mapping_log) as r:
        duration = r.duration_ns / 1e9
        counts = {t: i.count for t, i in r.topics.items()}
    assert duration >= 90.0
    assert clearance(world, xy).min() >= 0.22  # never closer than go2's radius
    assert np.hypot(*xy[-1]) < 0.3  # back near the start
    assert counts["/scan"] == pytest.approx(10 * duration, abs=2)
    assert counts["/imu/data"] == pytest.approx(200 * duration, abs=2)


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"world": "indor_room"}, ["unknown world 'indor_room'", "did you mean 'indoor_room'"]),
        ({"robot": "go3"}, ["unknown robot 'go3'", "did you mean 'go2'"]),
        ({"scenario": "maping"}, ["unknown scenario 'maping'", "did you mean 'mapping'"]),
        ({"world": "walled_room"}, ["laid out for world 'indoor_room'"]),
    ],
)
def test_unknown_names_give_suggestions(kwargs, words):
    args = {"world": "indoor_room", "robot": "go2", "scenario": "mapping"} | kwargs
    with pytest.raises(ConfigError) as exc:
        prepare(**args)
    for w in words:
        assert w in str(exc.value)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_misspelled_key_wrong_type_and_malformed_yaml(tmp_path):
    bad = write(
        tmp_path / "r.yaml", Path(REPO / "config/robots/go2.yaml").read_text().replace("radius: 0.22", "raduis: 0.22")
    )
    with pytest.raises(ConfigError) as exc:
        prepare("indoor_room", str(bad), "mapping")
    assert str(bad) in str(exc.value) and "raduis" in str(exc.value) and "did you mean 'radius'" in str(exc.value)
    bad2 = write(
        tmp_path / "r2.yaml", Path(REPO / "config/robots/go2.yaml").read_text().replace("rate: 200.0", "rate: fast")
    )
    with pytest.raises(ConfigError) as exc:
        prepare("indoor_room", str(bad2), "mapping")
    assert "imu.rate" in str(exc.value) and "expected a number" in str(exc.value)
    bad3 = write(tmp_path / "w.yaml", "name: x\nobjects: [\n  - {name: a\n")
    with pytest.raises(ConfigError) as exc:
        prepare(str(bad3), "go2", "teleop")
    assert "malformed YAML" in str(exc.value) and "line" in str(exc.value)


def test_spawn_inside_obstacle_and_colliding_scenario(tmp_path):
    inside = write(
        tmp_path / "s.yaml",
        "name: s\nkind: teleop\nstart: [2.0, 1.5, 0.0]\ncommands: [{duration: 1.0, cmd: [0.1, 0, 0]}]\n",
    )
    with pytest.raises(ConfigError, match="spawn pose .* inside an obstacle"):
        prepare("indoor_room", "go2", str(inside))
    crash = write(tmp_path / "c.yaml", "name: c\nkind: teleop\ncommands: [{duration: 20.0, cmd: [0.3, 0, 0]}]\n")
    with pytest.raises(ConfigError, match="would collide"):
        prepare("indoor_room", "go2", str(crash))


def test_cli_errors_exit_nonzero_without_traceback_and_write_nothing(tmp_path):
    out = tmp_path / "x.mcap"
    proc = subprocess.run(
        NAVLOG + ["record", "--robot", "go3", "-o", str(out)], cwd=REPO, capture_output=True, text=True
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "did you mean 'go2'" in proc.stderr
    assert not out.exists() and not list(tmp_path.iterdir())


def test_existing_output_needs_force(teleop_log):
    with pytest.raises(NavlogError, match="already exists.*--force"):
        record(prepare("indoor_room", "go2", "teleop", seed=3), teleop_log, progress=False)


def _start_recording(out: Path) -> subprocess.Popen:
    return subprocess.Popen(
        NAVLOG + ["-q", "record", "--scenario", "mapping", "-o", str(out)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(path: Path, size: int, timeout: float = 120.0) -> None:
    end = time.time() + timeout
    while time.time() < end:
        if path.exists() and path.stat().st_size > size:
            return
        time.sleep(0.2)
    raise AssertionError(f"{path} did not grow past {size} bytes")


def test_progress_off_a_terminal_prints_every_decile_up_to_100_percent(tmp_path, capsys):
    res = record(prepare("indoor_room", "go2", "teleop", seed=3), tmp_path / "p.mcap")
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"recording: {d}%" for d in range(0, 101, 10)]
    assert not res.interrupted


def test_expected_duration_of_a_tour_is_its_path_not_max_duration(mapping_log):
    # the mapping tour takes 138 s of its 400 s max_duration; the bar's total must be near 138 s
    setup = prepare("indoor_room", "go2", "mapping", seed=7)
    with open_log(mapping_log) as r:
        actual = r.duration_ns / 1e9
    assert setup.scenario.max_duration == 400.0
    assert abs(expected_duration(setup) - actual) < 0.1 * actual
    assert expected_duration(prepare("indoor_room", "go2", "teleop")) == pytest.approx(17.0)


def test_summary_table_lists_every_topic_with_count_and_rate(tmp_path):
    res = record(prepare("indoor_room", "go2", "teleop", seed=3), tmp_path / "s.mcap", progress=False)
    text = format_summary(res)
    assert "\x1b[" not in text
    n, typ = res.topics["/scan"][1], res.topics["/scan"][0]
    row = next(line for line in text.splitlines() if line.split()[:1] == ["/scan"])
    assert row.split() == ["/scan", typ, str(n), f"{(n - 1) / res.sim_s:.2f}", "Hz"]
    assert len([line for line in text.splitlines() if line.lstrip().startswith("/")]) == len(res.topics)


def test_a_set_stop_event_ends_the_run_with_a_whole_file(tmp_path):
    import threading

    stop = threading.Event()
    stop.set()
    res = record(prepare("indoor_room", "go2", "teleop", seed=3), tmp_path / "stop.mcap", progress=False, stop=stop)
    assert res.interrupted and res.sim_s < 1.0
    with open_log(res.path) as r:
        assert not r.report.truncated


@pytest.mark.parametrize("max_duration, sim_s", [(1e-9, 0.0), (0.0015, 0.0), (0.5, 0.5)])
def test_the_run_ends_at_max_duration_between_two_simulator_steps(tmp_path, max_duration, sim_s):
    out = tmp_path / "short.mcap"
    code = (
        "import dataclasses\n"
        "from navlog.recorder.record import prepare, record\n"
        "s = prepare('indoor_room', 'go2', 'mapping', seed=11)\n"
        f"s.scenario = dataclasses.replace(s.scenario, max_duration={max_duration!r})\n"
        f"print(record(s, {str(out)!r}, progress=False).sim_s)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) == sim_s  # the last simulator step at or before max_duration
    with open_log(out) as r:
        assert not r.report.truncated


def test_ctrl_c_closes_the_file_cleanly(tmp_path):
    out = tmp_path / "int.mcap"
    proc = _start_recording(out)
    _wait_for(out.with_name(out.name + ".part"), 12_000_000)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "interrupted, file closed cleanly" in stdout
    with open_log(out) as r:
        assert not r.report.truncated and r.duration_ns > 1e9
        assert r.topics["/scan"].count > 10


def test_kill_9_then_recover(tmp_path):
    out = tmp_path / "killed.mcap"
    part = out.with_name(out.name + ".part")
    proc = _start_recording(out)
    _wait_for(part, 12_000_000)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    assert not out.exists()
    info = subprocess.run(NAVLOG + ["info", str(part)], cwd=REPO, capture_output=True, text=True)
    assert info.returncode == 2 and "truncated" in info.stderr and "Traceback" not in info.stderr
    fixed = tmp_path / "fixed.mcap"
    rec = subprocess.run(NAVLOG + ["recover", str(part), "-o", str(fixed)], cwd=REPO, capture_output=True, text=True)
    assert rec.returncode == 0, rec.stderr
    assert "kept" in rec.stdout and "the input was truncated" in rec.stdout
    with open_log(fixed) as r:
        kept = r.message_count
        assert kept > 1000 and r.duration_ns > 1e9
        assert sum(1 for _ in r.messages(["/scan"])) == r.topics["/scan"].count
    assert f"kept {kept} messages" in rec.stdout


def test_the_package_states_its_public_api():
    import importlib

    import navlog.recorder

    assert set(navlog.recorder.__all__) == set(navlog.recorder._MODULES)
    for name in navlog.recorder.__all__:
        module = importlib.import_module(f"navlog.recorder.{navlog.recorder._MODULES[name]}")
        assert getattr(navlog.recorder, name) is getattr(module, name)
