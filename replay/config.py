"""Typed configuration from YAML: dataclasses validated once, at the edge, with did-you-mean errors.

Every parameter set in navlog is a frozen dataclass. ``from_mapping`` turns a YAML mapping into one,
checking every key and type and naming the file and key path of anything wrong; ``to_mapping`` turns
it back into plain data (for manifests and hashes). ``apply_overrides`` applies ``a.b.c=value`` strings
from the command line.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import importlib.resources
import json
import os
import types
import typing
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


def suggest(word: str, choices: typing.Iterable[str]) -> str:
    """' (did you mean X?)' for the closest choice, or '' when nothing is close."""
    # keys read from YAML may be numbers or booleans; compare them as the text they were written as
    match = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean '{match[0]}'?)" if match else ""


def load_yaml(path: Path) -> Any:
    """Parse a YAML file; a syntax error names the file and line."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a YAML text file (binary content){_yaml_hint(path)}") from None
    return parse_yaml(text, str(path))


def parse_yaml(text: str, source: str) -> Any:
    """Parse YAML text; a syntax error or a self-referencing alias raises ConfigError naming ``source``."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(f"{source}:{where}: malformed YAML: {problem}") from None
    _refuse_cycles(doc, source, [])
    return doc


def _refuse_cycles(node: Any, source: str, inside: list[int]) -> None:
    """An alias inside its own anchor (``a: &x [*x]``) makes a structure that contains itself."""
    if not isinstance(node, (dict, list)):
        return
    if id(node) in inside:
        raise ConfigError(f"{source}: malformed YAML: an alias refers to a node that contains it; expand it")
    inside.append(id(node))
    for child in node.values() if isinstance(node, dict) else node:
        _refuse_cycles(child, source, inside)
    inside.pop()


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


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp))


def _convert(value: Any, tp: Any, where: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(value, arg, where)
            except ConfigError as exc:
                errors.append(str(exc))
        raise ConfigError(errors[0] if len(errors) == 1 else f"{where}: {value!r} fits none of {tp}")
    if origin is typing.Literal:
        if isinstance(value, bool) and {"on", "off"} <= set(args):
            return "on" if value else "off"  # YAML 1.1 reads a bare on/off as a boolean
        if value in args and not isinstance(value, bool):
            return value
        raise ConfigError(
            f"{where}: {value!r} is not one of {', '.join(map(repr, args))}"
            f"{suggest(str(value), [str(a) for a in args])}"
        )
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return from_mapping(tp, value, where)
    if origin in (list, tuple) or tp in (list, tuple):
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise ConfigError(f"{where}: expected {len(args)} values, got {len(value)}")
            return tuple(_convert(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
        item = args[0] if args else Any
        out = [_convert(v, item, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(out) if origin is tuple or tp is tuple else out
    if origin is dict or tp is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{where}: expected a mapping, got {value!r}")
        kt, vt = args if args else (Any, Any)
        return {_convert(k, kt, where): _convert(v, vt, f"{where}.{k}") for k, v in value.items()}
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {value!r}")
        return value
    raise ConfigError(f"{where}: unsupported type {_type_name(tp)}")


def from_mapping(cls: type[T], data: Any, where: str = "") -> T:
    """Build dataclass ``cls`` from a mapping, checking keys and types; ``where`` prefixes errors."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where or cls.__name__}: expected a mapping, got {data!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
    unknown = [k for k in data if k not in fields]
    if unknown:
        key = unknown[0]
        raise ConfigError(
            f"{where + '.' if where else ''}{key}: unknown key{suggest(str(key), fields)}; allowed: {', '.join(fields)}"
        )
    kwargs = {}
    for name, field in fields.items():
        key_where = f"{where + '.' if where else ''}{name}"
        if name in data:
            kwargs[name] = _convert(data[name], hints[name], key_where)
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise ConfigError(f"{key_where}: required key is missing")
    try:
        obj = cls(**kwargs)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{where or cls.__name__}: {exc}") from None
    return obj


def load_config(cls: type[T], path: Path, overrides: typing.Sequence[str] = ()) -> T:
    """Load dataclass ``cls`` from a YAML file, with ``key.path=value`` overrides; errors name the file."""
    data = load_yaml(path)
    data = apply_overrides(data if data is not None else {}, overrides)
    try:
        return from_mapping(cls, data)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


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
