"""Errors that navlog reports to users as one clear message (never a traceback)."""

from __future__ import annotations


class NavlogError(Exception):
    """An error whose message is meant for the user: it names the file, key or topic at fault."""


class ConfigError(NavlogError):
    """A configuration file or value is missing, malformed or misspelled."""


class LogError(NavlogError):
    """A log cannot be read, or lacks what was asked of it."""


class TruncatedLogError(LogError):
    """A log ends before its summary: it was cut off while being written."""


class SimulationError(NavlogError):
    """The simulation cannot go on: its physics diverged."""


class Terminated(KeyboardInterrupt):
    """SIGTERM to a ``navlog`` process (the command line raises it where the process runs), so that what it
    writes is cleaned up on the way out as after Ctrl-C; unlike Ctrl-C, the process's workers did not get it."""
