"""The command line stays thin and fast, and ``navlog`` names its public API."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

import navlog
from navlog.cli import COMMANDS, main

HEAVY = ("numpy", "scipy", "open3d", "mujoco", "rerun", "mcap", "rosbags")


def python(code: str) -> str:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout


def heavy_after(code: str) -> list[str]:
    """The heavy libraries loaded after running ``code`` in a fresh interpreter."""
    out = python(f"{code}\nimport json, sys\nprint(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})))")
    return sorted(set(json.loads(out.splitlines()[-1])) & set(HEAVY))


def test_import_navlog_is_light() -> None:
    assert heavy_after("import navlog") == []


def test_help_of_navlog_and_every_command_is_light() -> None:
    code = (
        "import contextlib, io, sys\n"
        "from navlog.cli import COMMANDS, main\n"
        "for argv in [['--help']] + [[c, '--help'] for c in COMMANDS]:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "        main(argv)\n"
    )
    assert heavy_after(code) == []


def test_every_public_name_resolves() -> None:
    assert len(navlog.__all__) == len(set(navlog.__all__))
    for name in navlog.__all__:
        assert getattr(navlog, name) is not None, name
        assert name in dir(navlog)
    assert navlog.run_demo.__module__ == "navlog.demo"
    assert issubclass(navlog.ConfigError, navlog.NavlogError)
    with pytest.raises(AttributeError):
        navlog.no_such_name  # noqa: B018


def test_help_keeps_the_examples_line_breaks(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["replay", "--help"])
    out = capsys.readouterr().out
    assert (
        "examples:\n  navlog replay run.mcap --pipeline mapping -o out/\n"
        "  navlog replay run.mcap --pipeline mapping --set pose_source=odom -o out-odom/\n" in out
    )
    assert "pipeline name (localization, mapping, navigation," in " ".join(out.split())


def test_every_command_has_a_module_with_register_and_run() -> None:
    import importlib

    for name in COMMANDS:
        module = importlib.import_module(f"navlog.commands.{name.replace('-', '_')}")
        assert callable(module.register) and callable(module.run), name


def test_metrics_choices_are_the_librarys() -> None:
    """The metrics command writes its choices down to keep its help light; they must agree."""
    from navlog.analysis.metrics import report, trajectory
    from navlog.commands import metrics

    assert metrics.PCD_FRAMES == report.PCD_FRAMES
    assert metrics.ALIGN_MODES == trajectory.ALIGN_MODES
    assert metrics.DELTA_UNITS == trajectory.DELTA_UNITS


def test_demo_refuses_a_full_output_folder(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    assert main(["demo", "-o", str(tmp_path)]) == 2
    assert "pass --force to replace it" in capsys.readouterr().err
    assert (tmp_path / "keep.txt").read_text() == "mine"


def test_skipped_note_sums_and_sorts_the_reasons() -> None:
    from navlog.commands import skipped_note

    assert skipped_note({}) == "" and skipped_note({"x": 0}) == ""
    assert skipped_note({"undecodable": 1, "cloud_empty": 2}) == "; skipped 3: cloud_empty x2; undecodable x1"


def test_quiet_before_or_after_the_command(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from navlog.cli import build_parser

    replay = ["replay", "a.mcap", "--pipeline", "mapping", "-o", "out"]
    for command in (None, "replay"):
        parser = build_parser(command)
        assert parser.parse_args(["-q", *replay]).quiet is True
        assert parser.parse_args([*replay, "-q"]).quiet is True
        assert parser.parse_args([*replay, "--quiet"]).quiet is True
        assert parser.parse_args(replay).quiet is False
    assert build_parser().parse_args(["ci", "run", "s.yaml", "-q"]).quiet is True  # an action's parser too
    assert build_parser().parse_args(["ci", "run", "s.yaml"]).quiet is False
    # through main: a command with -q after it runs (a bad log is still a one-line error)
    assert main(["info", str(tmp_path / "nope.mcap"), "-q"]) == 2
    assert "nope.mcap" in capsys.readouterr().err


def test_every_command_that_works_on_files_shows_an_example_in_its_help(capsys: pytest.CaptureFixture[str]) -> None:
    """Each command's --help ends with at least one example run of it (commands with actions show theirs on
    the action's help)."""
    for name in COMMANDS:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        out = capsys.readouterr().out
        assert re.search(rf"\nexamples?:\n  navlog {name} ", out), name
