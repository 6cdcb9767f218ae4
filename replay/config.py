"""Typed configuration from YAML: dataclasses validated once, at the edge, with did-you-mean errors.

Every parameter set in navlog is a frozen dataclass. ``from_mapping`` turns a YAML mapping into one,
checking every key, type and limit (``param``) and naming the file and key path of anything wrong;
``to_mapping`` turns it back into plain data (for manifests and hashes). ``apply_overrides`` applies
``a.b.c=value`` strings from the command line.

``ParamReader`` is the one reader of typed parameters: ``from_mapping`` stops at the first error;
Nav2 parameter files are read by a subclass that reports every problem at once with its line and
knows how Nav2 differs (``navlog.replay.nav2.schema.SectionReader``).
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import hashlib
import importlib.resources
import json
import os
import re
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import yaml

from navlog.errors import ConfigError

T = TypeVar("T")

CONFIG_PATH_ENV = "NAVLOG_CONFIG_PATH"


def builtin_config_dir() -> Path:
    """The folder of navlog's shipped YAML (the package ``navlog.config``)."""
    return Path(str(importlib.resources.files("navlog.config")))


def config_dirs() -> list[Path]:
    """Where named worlds, models, robots, scenarios, goals and pipelines are looked up, in order.

    The folders of ``$NAVLOG_CONFIG_PATH`` (separated like ``PATH``) come first, so a user's own
    files add to the built-in ones or replace one of the same name; the built-in files come last.
    """
    env = os.environ.get(CONFIG_PATH_ENV, "")
    return [Path(p).expanduser() for p in env.split(os.pathsep) if p] + [builtin_config_dir()]


def find_config(kind: str, name: str) -> Path | None:
    """The first ``KIND/NAME.yaml`` along the search path, or None."""
    for folder in config_dirs():
        path = folder / kind / f"{name}.yaml"
        if path.is_file():
            return path
    return None


def known_configs(kind: str) -> list[str]:
    """Names of every ``KIND/*.yaml`` along the search path, sorted."""
    return sorted({p.stem for folder in config_dirs() for p in (folder / kind).glob("*.yaml")})


def closest(word: str, choices: typing.Iterable[str]) -> str | None:
    """The choice closest to ``word``, or None when nothing is close."""
    # keys read from YAML may be numbers or booleans; compare them as the text they were written as
    match = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return match[0] if match else None


def suggest(word: str, choices: typing.Iterable[str]) -> str:
    """' (did you mean X?)' for the closest choice, or '' when nothing is close."""
    match = closest(word, choices)
    return f" (did you mean '{match}'?)" if match is not None else ""


def load_yaml(path: Path) -> Any:
    """Parse a YAML file; a syntax error names the file and line."""
    path = Path(path)
    return parse_yaml(read_yaml_text(path), str(path))


def read_yaml_text(path: Path) -> str:
    """The text of a YAML file; ConfigError naming the file when it cannot be read or is binary."""
    try:
        return Path(path).read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a YAML text file (binary content){_yaml_hint(Path(path))}") from None


MAX_YAML_DEPTH = 100  # nesting levels of a YAML document (navlog's and Nav2's files use fewer than 10)
MAX_YAML_NODES = 200_000  # nodes of a YAML document with its aliases expanded (a large Nav2 file: ~3,000)


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing nesting deeper than ``MAX_YAML_DEPTH`` while it composes (so a
    document of 20,000 levels ends at level ``MAX_YAML_DEPTH``, not in a ``RecursionError``)."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_YAML_DEPTH:
                mark = self.peek_event().start_mark
                raise yaml.composer.ComposerError(None, None, f"nested deeper than {MAX_YAML_DEPTH} levels", mark)
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


class _Dumper(yaml.SafeDumper):
    """PyYAML's safe dumper, quoting the text ``parse_yaml`` would read as a number (``dump_yaml``)."""


# YAML 1.2 (yaml-cpp, which ROS 2's parameter files and map_server's YAML are read with) reads an exponent without
# a dot or a sign (5e-2, 1.0e300) as a number; PyYAML's YAML 1.1 rules read it as text. What navlog writes is
# read back the same: its dumper quotes such text.
for _yaml_class in (_BoundedLoader, _Dumper):
    _yaml_class.add_implicit_resolver(
        "tag:yaml.org,2002:float",
        re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
        list("-+0123456789."),
    )


def dump_yaml(doc: Any) -> str:
    """``doc`` as YAML text (block style, keys in their order) that ``parse_yaml`` reads back as ``doc``."""
    return yaml.dump(doc, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=200)


def bounded_compose(text: str) -> yaml.Node | None:
    """The composed YAML node graph of ``text`` (no values built), nesting bounded as ``parse_yaml``'s;
    ``yaml.YAMLError`` when it is malformed or too deep."""
    loader = _BoundedLoader(text)  # a ``yaml.YAMLError`` for unprintable characters, as for the rest
    try:
        return loader.get_single_node()
    finally:
        loader.dispose()


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML text safely (no Python tags) within bounds: ConfigError naming ``source`` for a syntax
    error, nesting deeper than ``MAX_YAML_DEPTH``, an alias that contains itself, or more than
    ``MAX_YAML_NODES`` nodes once the aliases are expanded (an alias bomb). The bounds are checked on
    the composed document before anything is built, in time linear in its size."""
    try:
        loader = _BoundedLoader(text)  # (its reader refuses unprintable characters at once)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            _check_expanded_size(node, source)
            _check_unique_keys(node, source)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(
            f"{source}:{where}: malformed YAML: {problem}" if where else f"{source}: malformed YAML: {problem}"
        ) from None


def _check_unique_keys(root: yaml.Node, source: str) -> None:
    """ConfigError for a mapping that holds a key twice (YAML requires unique keys; PyYAML keeps the last one
    without a word, so the first was silently lost)."""
    seen: set[int] = set()
    stack = [root]
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            first: dict[str, int] = {}
            for key, _ in node.value:
                if isinstance(key, yaml.ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
                    line = key.start_mark.line + 1
                    if key.value in first:
                        raise ConfigError(
                            f"{source}: line {line}: key '{key.value}' appears twice in one mapping (first at line "
                            f"{first[key.value]}); YAML keys must be unique: keep one"
                        )
                    first[key.value] = line
        stack.extend(_children(node))


def _check_expanded_size(root: yaml.Node, source: str) -> None:
    """Refuse a composed document whose aliases make it contain itself, or expand it beyond
    ``MAX_YAML_NODES`` nodes: each node is visited once (a shared node's expanded size is kept)."""
    size: dict[int, int] = {}
    entered: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, finished = stack.pop()
        children = _children(node)
        if finished:
            size[id(node)] = min(1 + sum(size[id(c)] for c in children), MAX_YAML_NODES + 1)
            continue
        if id(node) in size:
            continue
        entered.add(id(node))
        stack.append((node, True))
        for child in children:
            if id(child) in entered and id(child) not in size:  # an ancestor: the node contains itself
                raise ConfigError(f"{source}: malformed YAML: an alias refers to a node that contains it; expand it")
            if id(child) not in size:
                stack.append((child, False))
    if size[id(root)] > MAX_YAML_NODES:
        raise ConfigError(
            f"{source}: malformed YAML: more than {MAX_YAML_NODES:,} values once its aliases are expanded "
            "(an alias bomb?); write the document out"
        )


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _yaml_hint(path: Path) -> str:
    """What to give instead of a binary file where YAML was expected (a map image, most often)."""
    if path.suffix.lower() in (".pgm", ".png", ".bmp", ".jpg", ".jpeg", ".tif", ".tiff"):
        yamls = sorted(p.name for p in path.parent.glob("*.yaml") if path.name in p.read_text(errors="replace"))
        named = f"; {path.parent / yamls[0]} names this image" if yamls else ""
        return f": this is a map image; give the map's YAML (map_server's map.yaml, which names the image){named}"
    return ""


def named_config(kind: str, name: str) -> Path:
    """The YAML file for a named world, robot, scenario or pipeline, with a suggestion if unknown."""
    path = find_config(kind, name)
    if path is not None:
        return path
    candidate = Path(name)
    if candidate.suffix in (".yaml", ".yml") and candidate.is_file():
        return candidate
    known = known_configs(kind)
    where = os.pathsep.join(str(d / kind) for d in config_dirs())
    raise ConfigError(
        f"unknown {kind[:-1]} '{name}'{suggest(name, known)}; known: {', '.join(known) or 'none'} "
        f"(searched {where}; add folders with ${CONFIG_PATH_ENV} or give a path)"
    )


ERROR = "error"
WARNING = "warning"
NOTE = "note"


@dataclass(frozen=True)
class Problem:
    """One thing wrong (or worth noting) in a parameter file: its severity, YAML key path and line."""

    severity: str  # error | warning | note
    path: str  # YAML key path, e.g. global_costmap.global_costmap.ros__parameters.obstacle_layer
    message: str
    line: int | None = None

    def format(self, file: str = "") -> str:
        where = f"{file}:{self.line}: " if file and self.line else (f"{file}: " if file else "")
        return f"{where}{self.severity}: {self.path}: {self.message}"


def param(default: Any = dataclasses.MISSING, *, ge=None, gt=None, le=None, lt=None, choices=None, **kw):
    """A dataclass field with the limits ``ParamReader`` enforces: a range (``ge``, ``gt``, ``le``, ``lt``)
    for a number, or the ``choices`` a value must be one of."""
    meta = {"ge": ge, "gt": gt, "le": le, "lt": lt, "choices": choices}
    if isinstance(default, (list, dict)):
        raise TypeError("use tuples for list defaults")
    return dataclasses.field(default=default, metadata=meta, **kw)


class Item(int):
    """The position of a list's item in a key path, shown as ``[i]``."""


def key_path(path: typing.Sequence[Any]) -> str:
    """``a.b[2].c`` for the key path ``("a", "b", Item(2), "c")``."""
    out = ""
    for i, part in enumerate(path):
        out += f"[{part}]" if isinstance(part, Item) else (f".{part}" if i else str(part))
    return out


class BoundError(ConfigError, ValueError):
    """A value beyond a bound that involves more than one field (``navlog.replay.limits``), raised by a
    parameter dataclass's ``__post_init__``: ``key`` is the field the message is reported on."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}")
        self.key = key
        self.message = message


class ParamError(ConfigError):
    """A value that does not fit its declared type (``mismatch``) or its limits, at key path ``path``."""

    def __init__(self, path: tuple, message: str, mismatch: bool = True) -> None:
        super().__init__(f"{key_path(path)}: {message}")
        self.path = path
        self.message = message
        self.mismatch = mismatch


# scalar type -> how a message names one value of it, and several
_SCALARS: dict[Any, tuple[str, str]] = {
    float: ("a number", "numbers"),
    int: ("an integer", "integers"),
    bool: ("true or false", "true or false values"),
    str: ("a string", "strings"),
}


# a limit of ``param`` -> whether a value is within it
_WITHIN = {
    "ge": lambda v, b: v >= b,
    "gt": lambda v, b: v > b,
    "le": lambda v, b: v <= b,
    "lt": lambda v, b: v < b,
}


def describe(tp: Any) -> str:
    """What a value of type ``tp`` is, as messages say it: ``a number``, ``a list of strings``, ..."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp in _SCALARS:
        return _SCALARS[tp][0]
    if origin in (typing.Union, types.UnionType):
        return " or ".join(describe(a) for a in args if a is not type(None))
    if origin is typing.Literal:
        return f"one of {', '.join(map(repr, args))}"
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return "a mapping of parameters"
    if origin is dict or tp is dict:
        return "a mapping"
    if origin in (list, tuple):
        fixed = origin is tuple and args[-1] is not Ellipsis
        items, count = (args, f"{len(args)} ") if fixed else (args[:1], "")
        if len(set(items)) == 1 and items[0] in _SCALARS:
            return f"a list of {count}{_SCALARS[items[0]][1]}"
        return f"a list of {count}values" if count else "a list"
    if tp in (list, tuple):
        return "a list"
    return getattr(tp, "__name__", str(tp))


@functools.cache
def _declared(cls: type) -> tuple[dict[str, Any], tuple[dataclasses.Field, ...]]:
    """The resolved type of each field of dataclass ``cls``, and its fields set through ``__init__``."""
    return typing.get_type_hints(cls), tuple(f for f in dataclasses.fields(cls) if f.init)


def _not_one_of(value: Any, options: typing.Sequence[Any], shown: str, path: tuple) -> ParamError:
    return ParamError(
        path, f"{value!r} is not one of {shown}{suggest(str(value), [str(o) for o in options])}", mismatch=False
    )


class ParamReader:
    """Reads YAML data into typed parameter dataclasses, checking every key, type and limit.

    ``read`` builds a dataclass from a mapping: each key must name a field (or a parameter the class
    lists in ``READ_ONLY``: accepted and noted as not implemented), each value must fit the field's
    type (a nested dataclass, a list, tuple, dict, union, ``Literal`` or scalar; an integer is taken
    as a float) and its ``param`` limits. Every problem becomes a ``Problem`` with its key path and,
    given ``lines`` (key path -> line), its line.

    A reader with ``strict`` set raises ``ConfigError`` (``path: message``) at the first error; one
    without collects every problem in ``problems``, leaves a refused value's field at its default
    and goes on. A subclass adapts the reading to a file format through the hooks ``prepare``,
    ``settable``, ``refused`` and ``unknown_key`` (Nav2's: ``navlog.replay.nav2.schema``).
    """

    strict = True

    def __init__(self, lines: typing.Mapping[tuple, int] | None = None) -> None:
        self.problems: list[Problem] = []
        self.lines = lines or {}

    def add(self, severity: str, path: tuple, message: str) -> None:
        """Note a problem at ``path`` (an error raises ConfigError when the reader is strict)."""
        line = None
        for n in range(len(path), 0, -1):
            line = self.lines.get(tuple(path[:n]))
            if line is not None:
                break
        problem = Problem(severity, key_path(path), message, line)
        if severity == ERROR and self.strict:
            raise ConfigError(f"{problem.path}: {message}")
        self.problems.append(problem)

    # -- hooks
    def prepare(self, value: Any, tp: Any, path: tuple) -> Any:
        """A field's value as the type conversion takes it (a format's own spelling of a value, rewritten)."""
        return value

    def settable(self, tp: Any) -> bool:
        """Whether a field of type ``tp`` is set from a key of its name (else only from ``read``'s ``extra``)."""
        return True

    def refused(self, err: ParamError, value: Any, tp: Any, path: tuple) -> None:
        """Report the value of field ``path`` that does not fit its type ``tp`` (``err`` says how)."""
        self.add(ERROR, err.path, err.message)

    def unknown_key(self, key: str, kpath: tuple, known: list[str], is_section: bool = False) -> None:
        """Report ``key``, which names none of the ``known`` fields and sections."""
        self.add(ERROR, kpath, f"unknown key{suggest(key, known)}; allowed: {', '.join(known)}")

    # -- values
    def convert(
        self, value: Any, tp: Any, path: tuple, meta: typing.Mapping[str, Any] | None = None
    ) -> tuple[bool, Any]:
        """(True, the value converted to ``tp`` within the limits ``meta``), or (False, None) once reported."""
        try:
            out = self._typed(self.prepare(value, tp, path), tp, path)
            if meta:
                self._check_limits(out, meta, path)
        except ParamError as err:
            self.refused(err, value, tp, path)
            return False, None
        return True, out

    def _check_limits(self, out: Any, meta: typing.Mapping[str, Any], path: tuple) -> None:
        if isinstance(out, (int, float)) and not isinstance(out, bool):
            for key, word in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<")):
                bound = meta.get(key)
                if bound is not None and not _WITHIN[key](out, bound):
                    raise ParamError(path, f"{out} is out of range: must be {word} {bound}", mismatch=False)
        choices = meta.get("choices")
        if choices and out not in choices:
            raise _not_one_of(out, choices, ", ".join(map(str, choices)), path)

    def _typed(self, value: Any, tp: Any, path: tuple) -> Any:
        origin = typing.get_origin(tp)
        args = typing.get_args(tp)
        if tp is Any:
            return value
        if origin in (typing.Union, types.UnionType):
            if value is None and type(None) in args:
                return None
            members = [a for a in args if a is not type(None)]
            if len(members) == 1:
                return self._typed(value, members[0], path)
            # the first member that takes the value (a collecting reader's section reports its own problems)
            for arg in members:
                try:
                    return self._typed(value, arg, path)
                except ConfigError:
                    continue
            raise ParamError(path, f"{value!r} fits none of {tp}")
        if origin is typing.Literal:
            if isinstance(value, bool) and {"on", "off"} <= set(args):
                return "on" if value else "off"  # YAML 1.1 reads a bare on/off as a boolean
            if value in args and not isinstance(value, bool):
                return value
            raise _not_one_of(value, args, ", ".join(map(repr, args)), path)
        if isinstance(tp, type) and dataclasses.is_dataclass(tp):
            return self.read(tp, value, path)
        if origin in (list, tuple) or tp in (list, tuple):
            if not isinstance(value, (list, tuple)):
                raise ParamError(path, f"expected {describe(tp)}, got {value!r}")
            if origin is tuple and args and args[-1] is not Ellipsis:
                if len(value) != len(args):
                    raise ParamError(path, f"expected {len(args)} values, got {len(value)}")
                return tuple(self._typed(v, a, path + (Item(i),)) for i, (v, a) in enumerate(zip(value, args)))
            item = args[0] if args else Any
            out = [self._typed(v, item, path + (Item(i),)) for i, v in enumerate(value)]
            return tuple(out) if origin is tuple or tp is tuple else out
        if origin is dict or tp is dict:
            if not isinstance(value, dict):
                raise ParamError(path, f"expected {describe(tp)}, got {value!r}")
            kt, vt = args if args else (Any, Any)
            return {self._typed(k, kt, path): self._typed(v, vt, path + (k,)) for k, v in value.items()}
        if tp in _SCALARS:
            taken = (int, float) if tp is float else tp
            if isinstance(value, bool) != (tp is bool) or not isinstance(value, taken):
                raise ParamError(path, f"expected {describe(tp)}, got {value!r}")
            return float(value) if tp is float else value
        raise ParamError(path, f"unsupported type {describe(tp)}", mismatch=False)

    # -- sections
    def read(
        self,
        cls: type[T],
        data: Any,
        path: tuple = (),
        *,
        sections: tuple[str, ...] = (),
        extra: dict | None = None,
        skip: tuple[str, ...] = (),
    ) -> T:
        """Build dataclass ``cls`` from mapping ``data`` found at key path ``path``.

        ``sections`` are keys the caller reads itself (listed among the known keys), ``skip`` keys it
        ignores; ``extra`` gives fields their values directly (those ``settable`` refuses, mostly).
        """
        here = path or (cls.__name__,)
        if data is None:
            data = {}
        if not isinstance(data, dict):
            self.add(ERROR, here, f"expected {describe(cls)}, got {data!r}")
            data = {}
        hints, all_fields = _declared(typing.cast(type, cls))
        fields = {f.name: f for f in all_fields if self.settable(hints[f.name])}
        read_only = set(getattr(cls, "READ_ONLY", ()))
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            kpath = path + (key,)
            name = str(key)
            if name in sections or name in skip:
                continue
            if name in fields:
                ok, out = self.convert(value, hints[name], kpath, fields[name].metadata)
                if ok:
                    kwargs[name] = out
            elif name not in read_only:
                self.unknown_key(name, kpath, [*fields, *sections], is_section=isinstance(value, dict))
            if name in read_only:
                self.add(NOTE, kpath, "read, not implemented by navlog")
        given = {str(k) for k in data} | set(extra or ())
        for name, f in fields.items():
            if name not in given and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                self.add(ERROR, path + (name,), "required key is missing")
        kwargs.update(extra or {})
        try:
            return cls(**kwargs)
        except BoundError as exc:
            self.add(ERROR, path + (exc.key,), exc.message)
            return cls()
        except (TypeError, ValueError) as exc:
            failure = str(exc)
        self.add(ERROR, here, failure)
        return cls()


def from_mapping(cls: type[T], data: Any, where: str = "") -> T:
    """Build dataclass ``cls`` from a mapping, checking keys, types and limits; ``where`` prefixes errors.

    The first problem raises ConfigError naming its key path (``ParamReader``, strict).
    """
    return ParamReader().read(cls, data, (where,) if where else ())


def load_config(cls: type[T], path: Path, overrides: typing.Sequence[str] = ()) -> T:
    """Load dataclass ``cls`` from a YAML file, with ``key.path=value`` overrides; an error names the file or,
    when the file alone is valid, the first override that makes the parameters invalid."""
    data = load_yaml(path)
    base = data if data is not None else {}
    data = apply_overrides(base, overrides)
    try:
        return from_mapping(cls, data)
    except ConfigError as exc:
        raise ConfigError(f"{_blamed(cls, base, overrides, path, str(exc))}: {exc}") from None


def _blamed(cls: type, base: dict, overrides: typing.Sequence[str], path: Path, error: str) -> str:
    """What ``error`` of a failed ``load_config`` is blamed on: the file when the file alone fails with it, else
    the first override after which the parameters fail with it (the file when none does: the overrides together)."""
    for n in range(len(overrides) + 1):
        try:
            from_mapping(cls, apply_overrides(base, overrides[:n]))
        except Exception as exc:  # any failure but this error blames nothing yet
            if str(exc) == error:
                return str(path) if n == 0 else f"override '{overrides[n - 1]}' (over {path})"
    return str(path)


def apply_overrides(data: dict, overrides: typing.Sequence[str]) -> dict:
    """Return a copy of ``data`` with each ``a.b.c=value`` applied (value parsed as YAML)."""
    out = json.loads(json.dumps(data))
    if overrides and not isinstance(out, dict):
        raise ConfigError(f"override '{overrides[0]}': the parameters are not a mapping of keys to values")
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"override '{item}': expected KEY=VALUE, e.g. resolution=0.1")
        key, raw = item.split("=", 1)
        value = parse_yaml(raw, f"override '{item}'")
        node = out
        parts = key.strip().split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(f"override '{item}': '{part}' is not a section")
        node[parts[-1]] = value
    return out


def to_mapping(obj: Any) -> Any:
    """Plain data (dicts, lists, numbers, strings) for a dataclass tree, for manifests and hashes."""
    if dataclasses.is_dataclass(obj):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_mapping(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): to_mapping(v) for k, v in obj.items()}
    return obj


def config_hash(obj: Any) -> str:
    """sha256 of the canonical JSON form of a configuration tree."""
    text = json.dumps(to_mapping(obj), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
