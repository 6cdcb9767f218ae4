"""Security rules, each tested: YAML only through safe loading and nothing read is unpickled or evaluated;
names taken from logs, suites and baselines cannot lead a write outside the output folder; a symlink at an
output path is replaced, never written through; a spawned Rerun viewer listens on this machine only."""

from __future__ import annotations

import hashlib
import json
import re
import socket
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from navlog.cli import main
from navlog.errors import ConfigError, NavlogError

PACKAGE_DIRS = ("recorder", "replay", "analysis", "navlog")
UNSAFE = {
    "yaml.load(": re.compile(r"\byaml\.load\("),
    "yaml.unsafe_load": re.compile(r"\byaml\.(unsafe_load|full_load|load_all)\b"),
    "pickle": re.compile(r"\b(c?pickle|dill|shelve)\b"),
    "marshal": re.compile(r"\bmarshal\b"),
    "eval(": re.compile(r"(?<![\w.])eval\("),
    "exec(": re.compile(r"(?<![\w.])exec\("),
}


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _files_under(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


# --- YAML only through safe loading; nothing read is unpickled or evaluated ---------------------------------


def test_installed_source_has_no_unsafe_loading_or_evaluation():
    import navlog.analysis
    import navlog.recorder
    import navlog.replay

    roots = [Path(m.__file__).parent for m in (navlog.recorder, navlog.replay, navlog.analysis, navlog)]
    assert sorted(r.name for r in roots) == sorted(PACKAGE_DIRS)
    files = sorted({p for r in roots for p in r.rglob("*.py")})
    assert len(files) > 100  # every module of the four package folders, not an empty glob
    found = []
    for path in files:
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            found += [f"{path}:{lineno}: {what}: {line.strip()}" for what, rx in UNSAFE.items() if rx.search(code)]
    assert found == []


def test_the_source_scan_finds_what_it_looks_for(tmp_path):
    """The patterns above are not vacuous: each catches the unsafe call and spares its safe neighbour."""
    bad = ["yaml.load(text)", "yaml.unsafe_load(t)", "import pickle", "import marshal", "eval(s)", "exec(code)"]
    good = ["yaml.safe_load(text)", "ast.literal_eval(s)", "model.eval()", "executor.exec_time"]
    assert [any(rx.search(b) for rx in UNSAFE.values()) for b in bad] == [True] * len(bad)
    assert [any(rx.search(g) for rx in UNSAFE.values()) for g in good] == [False] * len(good)


@pytest.mark.parametrize(
    "tag",
    [
        "!!python/object/apply:os.system ['touch {marker}']",
        "!!python/object/new:subprocess.Popen [['touch', '{marker}']]",
        "!!python/object:navlog.errors.NavlogError {{}}",
        "!!python/name:os.system",
    ],
)
def test_yaml_with_a_python_tag_is_refused_with_a_clear_error(tmp_path, tag):
    from navlog.replay.config import load_yaml

    marker = tmp_path / "executed"
    path = tmp_path / "params.yaml"
    path.write_text(f"resolution: 0.05\nhook: {tag.format(marker=marker)}\n")
    with pytest.raises(ConfigError, match=r"params\.yaml:.*line 2.*could not determine a constructor.*python/") as e:
        load_yaml(path)
    assert "Traceback" not in str(e.value)
    assert not marker.exists()


def test_cli_refuses_a_python_tag_in_a_pipeline_parameter_file(tmp_path, capsys, teleop_log):
    marker = tmp_path / "executed"
    params = tmp_path / "mapping.yaml"
    params.write_text(f"pose_source: !!python/object/apply:os.system ['touch {marker}']\n")
    code = main(
        ["replay", str(teleop_log), "--pipeline", "mapping", "--params", str(params), "-o", str(tmp_path / "o")]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert f"{params}:" in err and "malformed YAML" in err and "Traceback" not in err
    assert not marker.exists() and not (tmp_path / "o").exists()


# --- names from suites, baselines and logs stay inside the output folder ------------------------------------


def _suite(tmp_path: Path, suite_name: str, case_name: str) -> Path:
    path = tmp_path / "suites" / "s.yaml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(
        textwrap.dedent(f"""\
            name: '{suite_name}'
            baselines: baselines
            cases:
              - name: '{case_name}'
                log: run.mcap
                pipeline: mapping
            """)
    )
    return path


@pytest.mark.parametrize("name", ["../../evil", "/tmp/evil", "a/../../evil", "..", ".hidden", "a\\..\\b"])
def test_suite_and_case_names_that_would_leave_the_baselines_folder_are_refused(tmp_path, name):
    from navlog.analysis.ci.suite import load_suite

    assert load_suite(_suite(tmp_path, "ok", "ok_case")).name == "ok"  # the same file with plain names loads
    with pytest.raises(ConfigError, match=r"s\.yaml.*name.*names the baselines? folder"):
        load_suite(_suite(tmp_path, name, "ok_case"))
    with pytest.raises(ConfigError, match=r"s\.yaml: case .*: name: .*names the baseline folder"):
        load_suite(_suite(tmp_path, "ok", name))


@pytest.mark.parametrize(
    ("name", "stored"),
    [
        ("../../evil.yaml", "../../evil.yaml"),
        ("map.yaml", "../../../etc/passwd"),
        ("/tmp/evil.json", None),
        ("..", None),
    ],
)
def test_a_baseline_naming_files_outside_its_folder_is_refused(tmp_path, name, stored):
    from navlog.analysis.ci.baselines import SCHEMA, read_baseline

    folder = tmp_path / "baselines" / "suite" / "case"
    folder.mkdir(parents=True)
    entry = {"sha256": "0" * 64, "bytes": 1, "stored": stored}
    ok = {"schema": SCHEMA, "case": "case", "provenance": {}, "outputs": {"map.yaml": {**entry, "stored": None}}}
    (folder / "baseline.json").write_text(json.dumps(ok))
    assert read_baseline(folder).outputs.keys() == {"map.yaml"}
    (folder / "baseline.json").write_text(json.dumps({**ok, "outputs": {name: entry}}))
    with pytest.raises(NavlogError, match=r"baseline\.json: output name .* not a plain file name"):
        read_baseline(folder)


def test_write_baseline_stays_in_its_folder_and_replaces_a_symlinked_one(tmp_path):
    from navlog.analysis.ci.baselines import read_baseline, write_baseline

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("precious")
    out = tmp_path / "run"
    out.mkdir()
    (out / "metrics.json").write_text('{"ate": 0.01}\n')
    folder = tmp_path / "baselines" / "suite" / "case"
    folder.parent.mkdir(parents=True)
    folder.symlink_to(elsewhere, target_is_directory=True)
    write_baseline(folder, {"metrics.json": out / "metrics.json"}, {"pipeline": "mapping"}, label="case")
    assert not folder.is_symlink() and read_baseline(folder).outputs["metrics.json"]["stored"] == "metrics.json"
    assert sorted(p.name for p in elsewhere.iterdir()) == ["keep.txt"]
    assert sorted(p.name for p in folder.parent.iterdir()) == ["case"]  # no temporary folder left


@pytest.fixture(scope="module")
def hostile_topic_log(tmp_path_factory) -> Path:
    """A log whose topics are named like paths that climb out of a folder."""
    from navlog.replay import messages
    from navlog.replay.io.logwriter import McapLogWriter

    out = tmp_path_factory.mktemp("hostile") / "hostile.mcap"
    store = messages.typestore()
    text = store.types["std_msgs/msg/String"](data="x")
    with McapLogWriter(out) as w:
        for i, topic in enumerate(["/../../x", "/../../../tmp/navlog_evil", "/a/../../b", "/ok"]):
            for k in range(3):
                w.write_raw(
                    topic,
                    "std_msgs/msg/String",
                    (10 * k + i + 1) * 1_000_000,
                    messages.serialize(text, "std_msgs/msg/String"),
                )
    return out


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_export_of_path_like_topics_writes_only_inside_its_folder(tmp_path, hostile_topic_log, storage):
    from rosbags.rosbag2 import Reader

    work = tmp_path / "work"
    work.mkdir()
    out = work / "bag"
    assert main(["export", str(hostile_topic_log), "--to", "rosbag2", "--storage", storage, "-o", str(out)]) == 0
    ext = {"sqlite3": ".db3", "mcap": ".mcap"}[storage]
    assert _files_under(tmp_path) == {work, out, out / "metadata.yaml", out / f"bag{ext}"}
    with Reader(out) as r:
        assert sorted(c.topic for c in r.connections) == ["/../../../tmp/navlog_evil", "/../../x", "/a/../../b", "/ok"]
        assert r.message_count == 12
    assert not Path("/tmp/navlog_evil").exists()


def test_view_of_path_like_topics_writes_only_its_rrd(tmp_path, hostile_topic_log):
    work = tmp_path / "work"
    work.mkdir()
    assert main(["view", str(hostile_topic_log), "--save", str(work / "v.rrd")]) == 0
    assert _files_under(tmp_path) == {work, work / "v.rrd"}


# --- a symlink at an output path is replaced, never written through -----------------------------------------


@pytest.fixture()
def target(tmp_path) -> Path:
    """A file elsewhere that a symlinked output points at; it must keep its bytes."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    path = elsewhere / "precious.bin"
    path.write_bytes(b"precious bytes\n")
    return path


def test_record_force_onto_a_symlink_replaces_the_link_not_its_target(tmp_path, target, capsys):
    from navlog.replay.io import open_log

    link = tmp_path / "link.mcap"
    link.symlink_to(target)
    part = tmp_path / "link.mcap.part"  # a stale temporary that is also a link elsewhere
    other = target.with_name("other.bin")
    other.write_bytes(b"other bytes\n")
    part.symlink_to(other)
    argv = ["record", "--world", "indoor_room", "--scenario", "teleop", "--no-noise", "-o", str(link)]
    assert main(argv) == 2  # without --force the link's target counts as an existing output
    assert "already exists" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0
    assert target.read_bytes() == b"precious bytes\n" and other.read_bytes() == b"other bytes\n"
    assert not link.is_symlink() and not part.exists()
    with open_log(link) as reader:
        assert reader.topics["/scan"].count == 171 and not reader.report.truncated


def test_recover_onto_a_symlinked_temporary_does_not_write_through_it(tmp_path, target, teleop_log):
    from navlog.replay.io.recovery import recover_mcap

    broken = tmp_path / "broken.mcap"
    broken.write_bytes(teleop_log.read_bytes()[: teleop_log.stat().st_size // 2])
    out = tmp_path / "rec.mcap"
    (tmp_path / "rec.mcap.part").symlink_to(target)
    res = recover_mcap(broken, out)
    assert res.messages > 0 and not res.complete
    assert target.read_bytes() == b"precious bytes\n" and out.is_file() and not out.is_symlink()


def test_save_map_replaces_symlinks_at_the_yaml_and_the_image(tmp_path, target):
    from navlog.replay.io.map_server import load_map, save_map
    from navlog.replay.occupancy_map import OccupancyMap

    image_target = target.with_name("image.bin")
    image_target.write_bytes(b"image bytes\n")
    (tmp_path / "m.yaml").symlink_to(target)
    (tmp_path / "m.pgm").symlink_to(image_target)
    grid = OccupancyMap(np.array([[-1, 0, 100], [0, 0, 100]], dtype=np.int8), 0.05, (-1.0, -2.0, 0.0))
    yaml_path, pgm_path = save_map(grid, tmp_path / "m.yaml")
    assert target.read_bytes() == b"precious bytes\n" and image_target.read_bytes() == b"image bytes\n"
    assert not yaml_path.is_symlink() and not pgm_path.is_symlink()
    assert load_map(yaml_path).data.tolist() == [[-1, 0, 100], [0, 0, 100]]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "m.pgm", "m.yaml"]  # no temporaries


def test_replay_force_onto_a_symlinked_folder_leaves_the_folder_elsewhere_alone(tmp_path, teleop_log):
    from navlog.replay.io.map_server import load_map

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "map.yaml").write_text("precious\n")
    out = tmp_path / "out"
    out.symlink_to(elsewhere, target_is_directory=True)
    argv = ["replay", str(teleop_log), "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", str(out), "--force"]
    assert main(argv) == 0
    assert sorted(p.name for p in elsewhere.iterdir()) == ["map.yaml"]
    assert (elsewhere / "map.yaml").read_text() == "precious\n"
    assert not out.is_symlink() and load_map(out / "map.yaml").resolution == 0.05
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "out"]


@pytest.mark.parametrize("kind", ["rosbag2", "rrd", "tum"])
def test_export_and_view_force_onto_a_symlink_leave_its_target_alone(tmp_path, target, teleop_log, kind):
    name = {"rosbag2": "bag", "rrd": "v.rrd", "tum": "t.tum"}[kind]
    link = tmp_path / name
    link.symlink_to(target)
    argv = {
        "rosbag2": ["export", str(teleop_log), "--to", "rosbag2", "--topics", "/odom", "-o", str(link)],
        "rrd": ["view", str(teleop_log), "--save", str(link)],
        "tum": ["export", str(teleop_log), "--to", "tum", "--topic", "/odom", "-o", str(link)],
    }[kind]
    assert main([*argv, "--force"]) == 0
    assert target.read_bytes() == b"precious bytes\n"
    assert not link.is_symlink() and link.exists()


# --- every server listens on this machine unless asked otherwise --------------------------------------------

FAKE_VIEWER = """\
import json, socket, sys, time
args = dict(a.lstrip("-").split("=", 1) for a in sys.argv[1:] if "=" in a)
open({argv_file!r}, "w").write(json.dumps(sys.argv[1:]))
bind = args.get("bind", "0.0.0.0")
s = socket.create_server((bind, int(args["port"])), family=socket.AF_INET6 if ":" in bind else socket.AF_INET)
time.sleep(3)
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_a_spawned_viewer_listens_on_localhost_only(tmp_path, monkeypatch):
    """Rerun's own spawn starts the viewer without --bind (its default is 0.0.0.0, every interface);
    navlog passes --bind=127.0.0.1 and streams to 127.0.0.1."""
    import rerun as rr

    from navlog.analysis.view.log_view import VIEWER_BIND, spawn_viewer

    argv_file = tmp_path / "argv.json"
    exe = tmp_path / "bin" / "rerun"
    exe.parent.mkdir()
    exe.write_text(f"#!{sys.executable}\n" + FAKE_VIEWER.format(argv_file=str(argv_file)))
    exe.chmod(0o755)
    monkeypatch.setenv("PATH", f"{exe.parent}:/usr/bin:/bin")
    port = _free_port()
    rec = rr.RecordingStream("navlog-test")
    urls = []
    monkeypatch.setattr(rec, "connect_grpc", lambda url=None, **k: urls.append(url))
    spawn_viewer(rec, port=port)
    args = json.loads(argv_file.read_text())
    assert VIEWER_BIND == "127.0.0.1"
    assert f"--port={port}" in args and "--bind=127.0.0.1" in args
    assert urls == [f"rerun+http://127.0.0.1:{port}/proxy"]
    spawn_viewer(rec, port=_free_port(), bind="::1")  # asked otherwise: the address given, IPv6 in brackets
    assert "--bind=::1" in json.loads(argv_file.read_text()) and urls[-1].startswith("rerun+http://[::1]:")


def test_the_view_command_spawns_through_the_localhost_viewer(monkeypatch, teleop_log, capsys):
    from navlog.analysis.view import log_view

    seen = []

    def spawn(rec, *, bind=log_view.VIEWER_BIND):
        seen.append(bind)
        raise NavlogError("no display in the test")

    monkeypatch.setattr(log_view, "spawn_viewer", spawn)
    monkeypatch.setenv("DISPLAY", ":99")  # past the display check (--spawn refuses at once without one)
    assert main(["view", str(teleop_log), "--spawn"]) == 2
    assert seen == ["127.0.0.1"] and "no display in the test" in capsys.readouterr().err
