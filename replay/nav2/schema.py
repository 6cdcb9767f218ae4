"""How navlog reads a Nav2 parameter section into a typed dataclass and reports what is wrong with it.

A parameter dataclass declares each parameter as a field with Nav2's default; ``param`` adds the
range and choice limits Nav2 enforces. ``SectionReader.read`` builds a dataclass from a YAML
mapping: a value of the wrong type or out of range is reported and replaced by the default, an
unknown key is reported with a did-you-mean (or as renamed by Nav2), a key the class lists in
``READ_ONLY`` is accepted and noted as not implemented. Every report is a ``Problem`` with its YAML
path and the line of the key (``ERROR``, ``WARNING`` or ``NOTE``).

Plugin sections (a layer, a planner, ...) are read by ``navlog.replay.nav2.plugins``.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from navlog.replay.config import suggest

ERROR = "error"
WARNING = "warning"
NOTE = "note"


@dataclass(frozen=True)
class Problem:
    severity: str  # error | warning | note
    path: str  # YAML key path, e.g. global_costmap.global_costmap.ros__parameters.obstacle_layer
    message: str
    line: int | None = None

    def format(self, file: str = "") -> str:
        where = f"{file}:{self.line}: " if file and self.line else (f"{file}: " if file else "")
        return f"{where}{self.severity}: {self.path}: {self.message}"


def param(default: Any = dataclasses.MISSING, *, ge=None, gt=None, le=None, lt=None, choices=None, **kw):
    """A dataclass field with range / choice metadata used by the reader."""
    meta = {"ge": ge, "gt": gt, "le": le, "lt": lt, "choices": choices}
    if isinstance(default, (list, dict)):
        raise TypeError("use tuples for list defaults")
    return field(default=default, metadata=meta, **kw)


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


class SectionReader:
    """Reads YAML sections into parameter dataclasses, collecting every problem with its path and line."""

    def __init__(self, lines: dict[tuple, int]) -> None:
        self.problems: list[Problem] = []
        self.lines = lines

    def add(self, severity: str, path: tuple, message: str) -> None:
        line = None
        for n in range(len(path), 0, -1):
            line = self.lines.get(tuple(path[:n]))
            if line is not None:
                break
        self.problems.append(Problem(severity, ".".join(str(p) for p in path), message, line))

    # -- values
    def convert(self, value: Any, tp: Any, path: tuple, meta: Mapping[str, Any]) -> tuple[bool, Any]:
        name = path[-1]
        origin = typing.get_origin(tp)
        ok, out = True, value
        if tp is bool:
            ok = isinstance(value, bool)
            expected = "true or false"
        elif tp is int:
            ok = isinstance(value, int) and not isinstance(value, bool)
            expected = "an integer"
        elif tp is float:
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            out = float(value) if ok else value
            expected = "a number"
        elif tp is str:
            ok = isinstance(value, str)
            expected = "a string"
            if name in ("footprint", "points") and isinstance(value, list):
                # Humble's collision monitor `points` is a flat list [x1, y1, x2, y2, ...]
                if (
                    name == "points"
                    and value
                    and all(isinstance(v, (int, float)) for v in value)
                    and len(value) % 2 == 0
                ):
                    return True, str([[float(value[i]), float(value[i + 1])] for i in range(0, len(value), 2)])
                self.add(
                    ERROR,
                    path,
                    'expected a string like "[[0.2, 0.2], [0.2, -0.2], ...]", got a list '
                    "(ROS 2 parameters cannot hold nested lists: quote it)",
                )
                return False, None
        elif origin is tuple and typing.get_args(tp)[0] is str:
            if isinstance(value, str):  # costmap observation_sources: "scan cloud"
                return True, tuple(value.split())
            ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
            out = tuple(value) if ok else value
            expected = "a list of strings"
        elif origin is tuple:
            ok = isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            out = tuple(float(v) for v in value) if ok else value
            expected = "a list of numbers"
        else:
            return True, value
        if not ok:
            self.add(ERROR, path, f"expected {expected}, got {value!r}; Nav2 would refuse it (default used)")
            return False, None
        if isinstance(out, (int, float)) and not isinstance(out, bool):
            for key, test, word in (
                ("ge", lambda v, b: v >= b, ">="),
                ("gt", lambda v, b: v > b, ">"),
                ("le", lambda v, b: v <= b, "<="),
                ("lt", lambda v, b: v < b, "<"),
            ):
                bound = meta.get(key)
                if bound is not None and not test(out, bound):
                    self.add(ERROR, path, f"{out} is out of range: must be {word} {bound}")
                    return False, None
        choices = meta.get("choices")
        if choices and out not in choices:
            self.add(ERROR, path, f"{out!r} is not one of {', '.join(choices)}{suggest(str(out), choices)}")
            return False, None
        return True, out

    def read(
        self,
        cls: type,
        data: Any,
        path: tuple,
        *,
        sections: tuple[str, ...] = (),
        extra: dict | None = None,
        skip: tuple[str, ...] = (),
    ) -> Any:
        """Build ``cls`` from mapping ``data``; ``sections`` are sub-mapping names the caller handles."""
        if data is None:
            data = {}
        if not isinstance(data, dict):
            self.add(ERROR, path, f"expected a mapping of parameters, got {data!r}")
            data = {}
        hints = typing.get_type_hints(cls)
        fields = {f.name: f for f in dataclasses.fields(cls) if f.init and typing.get_origin(hints[f.name]) is not dict}
        read_only = set(getattr(cls, "READ_ONLY", ()))
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            kpath = path + (key,)
            key = str(key)
            if key in sections or key in skip:
                continue
            if key in fields:
                ok, out = self.convert(value, hints[key], kpath, fields[key].metadata)
                if ok:
                    kwargs[key] = out
                if key in read_only:
                    self.add(NOTE, kpath, "read, not implemented by navlog")
                continue
            if key in read_only:
                self.add(NOTE, kpath, "read, not implemented by navlog")
                continue
            self.unknown_key(key, kpath, list(fields) + list(sections), is_section=isinstance(value, dict))
        if extra:
            kwargs.update(extra)
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:  # pragma: no cover - dataclass defaults always fit
            self.add(ERROR, path, str(exc))
            return cls()

    def unknown_key(self, key: str, kpath: tuple, known: list[str], is_section: bool = False) -> None:
        if key in RENAMED:
            self.add(ERROR, kpath, f"'{key}' was renamed to '{RENAMED[key]}' in Nav2; the old name is ignored")
            return
        hint = suggest(key, known)
        what = "section" if is_section else "parameter"
        if hint:
            self.add(ERROR, kpath, f"unknown {what} '{key}'{hint}; Nav2 would ignore it silently")
        else:
            self.add(WARNING, kpath, f"unknown {what} '{key}': Nav2 does not declare it and ignores it")
