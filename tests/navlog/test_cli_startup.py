"""What the ``navlog`` command line does to start and end quickly changes nothing a user sees: a command line
is parsed by its command's parser alone exactly as by the whole parser, and at the exit of a ``navlog``
process the garbage there is is still finalized before the rest is frozen."""

from __future__ import annotations

import argparse
import contextlib
import io
import subprocess
import sys

import pytest

from navlog.cli import COMMANDS, _command, build_parser, main


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return action


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    return _subparsers(parser).choices[command]


def _help(argv: list[str]) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main(argv)
    return out.getvalue()


def test_the_command_is_the_first_word_after_the_quiet_flag_only():
    assert _command(["replay", "log.mcap", "-o", "out"]) == "replay"
    assert _command(["-q", "world-map", "--help"]) == "world-map"
    assert _command(["--quiet", "-q", "info", "x"]) == "info"
    assert _command(["--help", "replay"]) is None  # the help of navlog itself lists every command
    assert _command(["--qu", "replay"]) is None  # an abbreviation: the whole parser decides
    assert _command(["no-such-command"]) is None and _command([]) is None and _command(["-q"]) is None


@pytest.mark.parametrize("command", COMMANDS)
def test_each_commands_help_is_the_same_from_its_parser_alone(command):
    whole = _subparser(build_parser(), command).format_help()
    assert _help([command, "--help"]) == whole
    alone = build_parser(command)
    assert _subparser(alone, command).format_help() == whole
    assert list(_subparsers(alone).choices) == [command]


def test_a_replay_command_line_parses_the_same_from_the_replay_parser_alone():
    argv = ["-q", "replay", "run.mcap", "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", "out", "--force"]
    whole, alone = build_parser().parse_args(argv), build_parser("replay").parse_args(argv)
    assert vars(whole) == vars(alone)
    assert (alone.quiet, alone.logs, alone.set, alone.force) == (True, ["run.mcap"], ["lidar_mapper=off"], True)


def test_navlogs_own_help_and_unknown_commands_still_list_every_command(capsys):
    text = _help(["--help", "replay"])
    assert all(f"\n    {name}" in text for name in COMMANDS)
    with pytest.raises(SystemExit):
        main(["replya", "x"])
    assert "invalid choice: 'replya' (choose from 'demo', 'record'," in capsys.readouterr().err


def _run(code: str) -> list[str]:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


CYCLE = (
    "import atexit, gc, sys\n"
    "atexit.register(lambda: print('frozen', gc.get_freeze_count() > 0, flush=True))\n"
    "class Cycle:\n"
    "    def __del__(self):\n"
    "        print('finalized', flush=True)\n"
    "gc.disable()\n"  # the cycle below is left for the exit
    "c = Cycle()\n"
    "c.me = c\n"
    "del c\n"
    "from navlog.cli import main\n"
)


def test_a_navlog_process_finalizes_its_garbage_then_freezes_the_rest_at_exit():
    lines = _run(CYCLE + "sys.argv = ['navlog', '--version']\nmain()\n")
    assert lines == ["navlog 0.1.0", "finalized", "frozen True"]


def test_main_called_with_arguments_leaves_the_callers_interpreter_alone():
    lines = _run(CYCLE + "main(['--version'])\n")
    assert lines[0] == "navlog 0.1.0" and "frozen False" in lines
