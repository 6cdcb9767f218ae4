"""Nav2's reading of a parameter section: the Nav2 knowledge ``ParamReader`` applies to a parameter file.

A parameter dataclass declares each parameter as a field with Nav2's default; ``param`` adds the
range and choice limits Nav2 enforces. ``SectionReader`` is navlog's one ``ParamReader``
(``navlog.replay.config``: types, limits, unknown keys with a did-you-mean), told how Nav2 differs:

- it never stops: a value of the wrong type or out of range is reported and replaced by the default,
  as Nav2 refuses it; a wrong type is reported for the parameter as a whole, as ROS 2 types it;
- ROS 2 parameters are scalars and arrays of them: a mapping field (a costmap's layers, a server's
  plugins) is filled by the node's reader from its sections, never from a key of its name;
- ROS 2 spellings of values: a list of names as one string (``observation_sources: "scan cloud"``),
  a footprint or polygon as a string, Humble's flat list of polygon points;
- an unknown key is reported with a did-you-mean, or as renamed by Nav2 (``RENAMED``); one with
  nothing close is a warning, as Nav2 ignores it.

Every report is a ``Problem`` with its YAML path and the line of the key (``ERROR``, ``WARNING`` or
``NOTE``). Plugin sections (a layer, a planner, ...) are read by ``navlog.replay.nav2.plugins``.
"""

from __future__ import annotations

import dataclasses
import typing
from typing import Any

from navlog.replay.config import ERROR, NOTE, WARNING, ParamError, ParamReader, Problem, describe, param, suggest

__all__ = ["DISTROS", "ERROR", "NOTE", "RENAMED", "WARNING", "Problem", "SectionReader", "param"]

# Parameters Nav2 renamed: old name -> new name. Nav2 ignores the old one silently.
RENAMED = {
    "raytrace_range": "raytrace_max_range",
    "obstacle_range": "obstacle_max_range",
    "max_obstacle_range": "obstacle_max_range",
    "min_obstacle_range": "obstacle_min_range",
    "max_raytrace_range": "raytrace_max_range",
    "min_raytrace_range": "raytrace_min_range",
    "progress_checker_plugin": "progress_checker_plugins",
    "max_points": "min_points",
}

# string parameters that hold a polygon, "[[x1, y1], [x2, y2], ...]"
POLYGON_STRINGS = ("footprint", "points")


# the Nav2 distributions a file is checked for (``SectionReader.distro``); Jazzy's parameters are the reference
DISTROS = ("jazzy", "humble")


class SectionReader(ParamReader):
    """Reads Nav2 parameter sections into dataclasses, collecting every problem with its path and line.

    ``distro`` is the Nav2 the file is written for: a name that is right in it is not warned about
    as another distribution's (Humble's ``progress_checker_plugin``, ``max_points``).
    """

    strict = False
    distro = "jazzy"
    tool = "Nav2"  # who reads the section, in the reports (a caller's reader of another node names that node)

    def prepare(self, value: Any, tp: Any, path: tuple) -> Any:
        """A list of names given as one string is split; a polygon given as a list is refused, or, in
        Humble's flat form ``[x1, y1, x2, y2, ...]`` of the collision monitor's ``points``, turned into
        the string Jazzy takes."""
        if tp is str and path[-1] in POLYGON_STRINGS and isinstance(value, list):
            if (
                path[-1] == "points"
                and value
                and all(isinstance(v, (int, float)) for v in value)
                and len(value) % 2 == 0
            ):
                return str([[float(value[i]), float(value[i + 1])] for i in range(0, len(value), 2)])
            raise ParamError(
                path,
                'expected a string like "[[0.2, 0.2], [0.2, -0.2], ...]", got a list '
                "(ROS 2 parameters cannot hold nested lists: quote it)",
                mismatch=False,
            )
        if isinstance(value, str) and typing.get_origin(tp) is tuple and typing.get_args(tp)[0] is str:
            return value.split()  # costmap observation_sources: "scan cloud"
        return value

    def settable(self, tp: Any) -> bool:
        return typing.get_origin(tp) is not dict and not dataclasses.is_dataclass(tp)

    def refused(self, err: ParamError, value: Any, tp: Any, path: tuple) -> None:
        if err.mismatch:
            self.add(ERROR, path, f"expected {describe(tp)}, got {value!r}; {self.tool} would refuse it (default used)")
        else:
            self.add(ERROR, err.path, err.message)

    def unknown_key(self, key: str, kpath: tuple, known: list[str], is_section: bool = False) -> None:
        if key in RENAMED:
            self.add(ERROR, kpath, f"'{key}' was renamed to '{RENAMED[key]}' in Nav2; the old name is ignored")
            return
        hint = suggest(key, known)
        what = "section" if is_section else "parameter"
        if hint:
            self.add(ERROR, kpath, f"unknown {what} '{key}'{hint}; {self.tool} would ignore it silently")
        else:
            self.add(WARNING, kpath, f"unknown {what} '{key}': {self.tool} does not declare it and ignores it")
