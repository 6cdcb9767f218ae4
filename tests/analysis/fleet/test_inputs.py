"""A fleet's logs from paths, folders, globs, list files and URLs; output names that never collide."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from navlog.analysis.fleet.inputs import LogSource, collect_logs
from navlog.errors import ConfigError


def _tree(root: Path) -> Path:
    """day1/{run.mcap, b.db3, notes.txt, bag/ (rosbag2), sub/ (no metadata)}, day2/run.mcap."""
    day1 = root / "day1"
    (day1 / "bag").mkdir(parents=True)
    (day1 / "sub").mkdir()
    (root / "day2").mkdir()
    for f in ("day1/run.mcap", "day1/b.db3", "day1/notes.txt", "day1/bag/metadata.yaml", "day1/sub/x.mcap"):
        (root / f).write_bytes(b"")
    (root / "day2" / "run.mcap").write_bytes(b"")
    return root


def _short(a: str) -> str:
    return hashlib.sha1(a.encode()).hexdigest()[:8]


def test_a_folder_gives_its_logs_and_rosbag2_folders_by_name_and_nothing_else(tmp_path):
    root = _tree(tmp_path)
    logs = collect_logs([root / "day1"])
    assert logs == [
        LogSource(str(root / "day1" / "b.db3"), "b"),
        LogSource(str(root / "day1" / "bag"), "bag"),
        LogSource(str(root / "day1" / "run.mcap"), "run"),
    ]
    # a rosbag2 folder or a file named alone is one log
    assert collect_logs([root / "day1" / "bag"]) == [LogSource(str(root / "day1" / "bag"), "bag")]
    assert collect_logs([root / "day1" / "bag" / ".." / "run.mcap", root / "day1" / "run.mcap"]) == [
        LogSource(str(root / "day1" / "run.mcap"), "run")
    ]


def test_logs_sharing_a_name_get_the_digest_of_their_address_whatever_the_order(tmp_path):
    root = _tree(tmp_path)
    one, two = str(root / "day1" / "run.mcap"), str(root / "day2" / "run.mcap")
    logs = collect_logs([one, two])
    assert [s.name for s in logs] == [f"run-{_short(one)}", f"run-{_short(two)}"]
    assert {s.address: s.name for s in collect_logs([two, one])} == {s.address: s.name for s in logs}
    assert len({s.name for s in logs}) == 2


def test_globs_and_list_files_with_comments_relative_paths_and_duplicates(tmp_path):
    root = _tree(tmp_path)
    listing = root / "fleet.txt"
    listing.write_text("# today's logs\nday1/run.mcap   # the first\n\nday1/*.db3\nday1/run.mcap\n")
    logs = collect_logs([str(root / "day2" / "*.mcap")], lists=[listing])
    assert [s.address for s in logs] == [
        str(root / "day2" / "run.mcap"),
        str(root / "day1" / "run.mcap"),
        str(root / "day1" / "b.db3"),
    ]
    assert [s.name for s in logs][2] == "b"
    assert sorted(s.address for s in collect_logs([str(root / "**" / "*.mcap")])) == sorted(
        str(p) for p in root.rglob("*.mcap")
    )


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda r: [str(r / "missing.mcap")], r"missing\.mcap: no such file or folder"),
        (lambda r: [str(r / "day1" / "sub" / "empty")], r"no such file or folder"),
        (lambda r: [str(r / "nothing-*.mcap")], r"nothing-\*\.mcap: the pattern matches no file or folder"),
        (lambda r: [], r"no logs given: name log files, folders of logs, glob patterns or a list file \(--list\)"),
    ],
)
def test_names_that_give_no_log_are_refused_naming_the_entry(tmp_path, make, message):
    root = _tree(tmp_path)
    with pytest.raises(ConfigError, match=message):
        collect_logs(make(root))


def test_a_folder_without_logs_and_a_bad_list_line_are_named(tmp_path):
    root = _tree(tmp_path)
    (root / "empty").mkdir()
    with pytest.raises(ConfigError, match=r"empty: no logs in this folder \(expected \.mcap or \.db3 files"):
        collect_logs([root / "empty"])
    listing = root / "l.txt"
    listing.write_text("day1/run.mcap\n\nday3/run.mcap\n")
    with pytest.raises(ConfigError, match=r"l\.txt, line 3: .*day3/run\.mcap: no such file or folder"):
        collect_logs([], lists=[listing])
    with pytest.raises(ConfigError, match=r"--list .*nope\.txt: cannot read"):
        collect_logs([], lists=[root / "nope.txt"])


def test_file_urls_are_local_paths_and_other_urls_go_through_fsspec(tmp_path):
    import fsspec

    root = _tree(tmp_path)
    assert collect_logs([f"file://{root}/day1/run.mcap"]) == [LogSource(str(root / "day1" / "run.mcap"), "run")]
    fs = fsspec.filesystem("memory")
    for name in (
        "fleet-inputs/a.mcap",
        "fleet-inputs/b.db3",
        "fleet-inputs/readme.md",
        "fleet-inputs/bag/metadata.yaml",
    ):
        fs.pipe_file(f"/{name}", b"x")
    try:
        logs = collect_logs(["memory://fleet-inputs"])
        assert logs == [
            LogSource("memory:///fleet-inputs/a.mcap", "a"),
            LogSource("memory:///fleet-inputs/b.db3", "b"),
            LogSource("memory:///fleet-inputs/bag", "bag"),
        ]
        assert [s.name for s in collect_logs(["memory://fleet-inputs/*.mcap"])] == ["a"]
        with pytest.raises(ConfigError, match=r"memory://fleet-inputs/none\.mcap: no such file or folder"):
            collect_logs(["memory://fleet-inputs/none.mcap"])
    finally:
        fs.rm("/fleet-inputs", recursive=True)


def test_a_replay_output_folder_is_not_a_log(tmp_path, capsys):
    from navlog.cli import main

    out = tmp_path / "out"
    out.mkdir()
    (out / "replay.mcap").write_bytes(b"\x89MCAP0\r\n")
    (out / "manifest.json").write_text('{"inputs": [{"file": "teleop.mcap", "bytes": 1, "sha256": "ab"}]}')
    with pytest.raises(
        ConfigError, match=r"out is a replay output folder, not a log; replay its input LOG \(teleop.mcap"
    ):
        collect_logs([out])
    assert main(["replay", str(out), "--pipeline", "mapping", "-o", str(tmp_path / "again")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a replay output folder, not a log" in err
    assert not (tmp_path / "again").exists()
    # inside a pattern such a folder is skipped, as a folder without logs is
    (tmp_path / "a.mcap").write_bytes(b"")
    assert [s.name for s in collect_logs([str(tmp_path / "*")])] == ["a"]


def test_logs_inside_the_fleets_own_output_folder_are_left_out(tmp_path):
    """`replay 'logs/**/*.mcap' -o logs/out` found the replays' own logs (out/a/replay.mcap) from an earlier
    run and replayed them as inputs."""
    (tmp_path / "logs" / "out" / "a").mkdir(parents=True)
    (tmp_path / "logs" / "a.mcap").write_bytes(b"")
    (tmp_path / "logs" / "out" / "a" / "replay.mcap").write_bytes(b"")
    pattern = str(tmp_path / "logs" / "**" / "*.mcap")
    assert len(collect_logs([pattern])) == 2
    assert collect_logs([pattern], output=tmp_path / "logs" / "out") == [
        LogSource(str(tmp_path / "logs" / "a.mcap"), "a")
    ]
