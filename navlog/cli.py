"""The ``navlog`` command line: a thin layer over the functions a Python user calls.

Each command lives in ``navlog/commands/<name>.py`` with ``register(subparsers)`` that adds its
parser and sets ``func``. A command module imports only ``argparse``-level things at the top and
the library inside its ``run``, so ``navlog --help`` and ``navlog COMMAND --help`` stay instant.
Errors meant for users (``NavlogError``) print one line and exit 2; Ctrl-C exits 130 after the
command has closed its files.
"""

from __future__ import annotations

import argparse
import atexit
import gc
import importlib
import logging
import os
import signal
import sys
from typing import Any

from navlog.errors import NavlogError, Terminated
from navlog.version import __version__

QUIET_HELP = "no progress bars or warnings"

# One module per command, in the order `navlog --help` lists them.
COMMANDS = [
    "demo",
    "record",
    "info",
    "check",
    "recover",
    "replay",
    "world-map",
    "world-gen",
    "pcd-to-map",
    "metrics",
    "diff",
    "ci",
    "view",
    "export",
    "check-config",
    "plan",
    "campaign",
]


class HelpFormatter(argparse.HelpFormatter):
    """Wraps each line of a description or epilog as a paragraph, keeps the line breaks, and prints
    indented lines (examples) exactly as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        fill = super()._fill_text
        return "\n".join(
            indent + line if not line.strip() or line[0].isspace() else fill(line, width, indent)
            for line in text.splitlines()
        )


class Parser(argparse.ArgumentParser):
    """An argument parser whose help keeps examples' line breaks; command parsers inherit it."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of ``navlog``; with ``command`` (a name in ``COMMANDS``) holding that command's parser
    only, which parses that command's arguments alike without importing and building the others'."""
    parser = Parser(
        prog="navlog",
        description="Record, replay, test and inspect mobile-robot navigation logs without ROS.",
        epilog="Run `navlog COMMAND --help` for the options of one command.",
    )
    parser.add_argument("--version", action="version", version=f"navlog {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS if command is None else [command]:
        importlib.import_module(f"navlog.commands.{name.replace('-', '_')}").register(sub)
    _quiet_anywhere(parser)
    return parser


def _quiet_anywhere(parser: argparse.ArgumentParser) -> None:
    """``-q`` after the command too (``navlog replay LOG -q``): every command's parser, and its actions'
    parsers (``navlog ci run``), take it; given nowhere, the top level's False stands."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):
                if not any("-q" in a.option_strings for a in child._actions):
                    child.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help=QUIET_HELP)
                _quiet_anywhere(child)


def _command(words: list[str]) -> str | None:
    """The command a command line runs when only ``-q`` may come before it (then its parser alone parses it
    alike), else None (``navlog --help COMMAND`` lists every command)."""
    for word in words:
        if word not in ("-q", "--quiet"):
            return word if word in COMMANDS else None
    return None


def _exit_without_teardown_collections() -> None:
    """At the exit of a ``navlog`` process: collect the garbage there is (its finalizers run as they always
    did), then freeze the rest. Tearing the modules down turns every class, function and module the imports
    made into cyclic garbage, and the interpreter's last collections would walk and free all of it one by
    one; frozen, it is left to the operating system with the process (the end of a 2D mapping replay: ~60 ms
    before, ~30 ms with the collection and the freeze)."""
    gc.collect()
    gc.freeze()


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def main(argv: list[str] | None = None) -> int:
    if argv is None:  # the process's own command line (`navlog ...`, `python -m navlog ...`): it ends after this
        atexit.register(_exit_without_teardown_collections)
        if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            signal.signal(signal.SIGTERM, _terminate)
    parser = build_parser(_command(sys.argv[1:] if argv is None else argv))
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR if args.quiet else logging.WARNING, format="navlog: warning: %(message)s")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except NavlogError as exc:
        print(f"navlog: error: {exc}", file=sys.stderr)
        return 2
    except Terminated:
        print("navlog: terminated (SIGTERM)", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("navlog: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":
    sys.exit(main())
