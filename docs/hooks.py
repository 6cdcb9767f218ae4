"""mkdocs hooks: reference pages generated from the code, so they cannot drift from it.

A page holds markers that the build replaces:

- ``<!-- navlog:cli -->``: every command's ``--help``, from the argparse parsers of ``navlog.cli``;
- ``<!-- navlog:params MODULE:CLASS -->``: every key of a typed parameter class (a dataclass), nested
  classes as dotted keys, with its type, its default and the comment the source gives it;
- ``<!-- navlog:api PACKAGE -->``: every public name of a package (its ``__all__``), with its
  signature and its docstring's first paragraph.

The API is read from the imported package rather than from its files: navlog installs ``recorder/``,
``replay/`` and ``analysis/`` under the one name ``navlog``, and its packages export their names lazily.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import io
import re
import tokenize
import types
import typing
from typing import Any

MARKER = re.compile(r"<!-- navlog:(cli|params|api) ?([\w.:]*) -->")


def on_page_markdown(markdown: str, **_: Any) -> str:
    def generate(m: re.Match[str]) -> str:
        kind, arg = m.group(1), m.group(2)
        if kind == "cli":
            return cli_reference()
        return params_reference(arg) if kind == "params" else api_reference(arg)

    return MARKER.sub(generate, markdown)


# ------------------------------------------------------------ the Python API
def api_reference(package: str) -> str:
    pkg = importlib.import_module(package)
    parts = [_first_paragraph(pkg.__doc__ or "")]
    for name in sorted(pkg.__all__):
        obj = getattr(pkg, name)
        kind = "class" if inspect.isclass(obj) else "function" if callable(obj) else "value"
        try:
            signature = str(inspect.signature(obj)) if callable(obj) else ""
        except (TypeError, ValueError):
            signature = ""
        where = getattr(obj, "__module__", package)
        parts.append(f"\n### `{name}`\n\n*{kind}* in `{where}`\n")
        if signature:
            parts.append(f"```python\n{name}{signature}\n```\n")
        doc = inspect.getdoc(obj) if kind != "value" else ""
        if doc:
            parts.append(_first_paragraph(doc))
    return "\n".join(parts)


def _first_paragraph(text: str) -> str:
    return inspect.cleandoc(text).split("\n\n")[0].replace("\n", " ") + "\n"


# ------------------------------------------------------------ the command line
def cli_reference() -> str:
    from navlog.cli import COMMANDS, build_parser

    parts = ["```text", build_parser().format_help().rstrip(), "```"]
    for name in COMMANDS:
        parser = build_parser(name)
        sub = next(a for a in parser._actions if isinstance(a.choices, dict))  # the subcommands' action
        assert isinstance(sub.choices, dict)
        parts += [f"\n## `navlog {name}`\n", "```text", sub.choices[name].format_help().rstrip(), "```"]
        nested = [a for a in sub.choices[name]._actions if isinstance(a.choices, dict)]
        for action in nested:  # e.g. navlog ci run
            assert isinstance(action.choices, dict)
            for child, child_parser in action.choices.items():
                parts += [f"\n### `navlog {name} {child}`\n", "```text", child_parser.format_help().rstrip(), "```"]
    return "\n".join(parts)


# ------------------------------------------------------------ typed parameters
def params_reference(spec: str) -> str:
    module_name, _, class_name = spec.partition(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    rows = ["| key | type | default | bounds | meaning |", "|---|---|---|---|---|"]
    rows += [f"| `{k}` | {t} | {d} | {b} | {m} |" for k, t, d, b, m in _rows(cls, "")]
    return "\n".join(rows)


def _bounds(f: dataclasses.Field) -> str:
    """The limits a field declares (``navlog.replay.config.param``): a range, or the choices."""
    meta = f.metadata
    if meta.get("choices"):
        return _cell(" | ".join(repr(c) for c in meta["choices"]))
    parts = [
        f"{op} {meta[key]:g}"
        for key, op in (("ge", "≥"), ("gt", ">"), ("le", "≤"), ("lt", "<"))
        if meta.get(key) is not None
    ]
    return ", ".join(parts)


def _rows(cls: type, prefix: str) -> list[tuple[str, str, str, str, str]]:
    hints = typing.get_type_hints(cls)
    notes = field_comments(cls)
    out = []
    for f in dataclasses.fields(cls):
        if not f.init or f.name.startswith("_"):
            continue
        hint = hints.get(f.name, f.type)
        default = _default(f)
        nested = _dataclass_of(hint)
        key = prefix + f.name
        if nested is not None and default is not dataclasses.MISSING:
            kind = "mapping" if default is not None else "mapping or null"
            out.append((key, kind, "" if default is not None else "`None`", "", _cell(notes.get(f.name, ""))))
            out += _rows(nested, key + ".")
            continue
        items = typing.get_args(hint)
        if typing.get_origin(hint) is list and items and _dataclass_of(items[0]) is not None:
            shown = "required" if default is dataclasses.MISSING else f"`{_short(default)}`"
            out.append((key, f"list of {items[0].__name__}", shown, "", _cell(notes.get(f.name, ""))))
            out += _rows(items[0], key + "[].")
            continue
        shown = "required" if default is dataclasses.MISSING else f"`{_short(default)}`"
        out.append((key, _cell(_type_name(hint)), shown, _bounds(f), _cell(notes.get(f.name, ""))))
    return out


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def _dataclass_of(hint: Any) -> type | None:
    """The dataclass ``hint`` names, also as ``X | None``."""
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return hint
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        classes = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(classes) == 1:
            return _dataclass_of(classes[0])
    return None


def _type_name(hint: Any) -> str:
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        return " | ".join(repr(a) for a in typing.get_args(hint))
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_name(a) for a in typing.get_args(hint))
    if origin is not None:
        args = ", ".join(_type_name(a) for a in typing.get_args(hint) if a is not Ellipsis)
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if hint is type(None):
        return "null"
    return getattr(hint, "__name__", str(hint))


def _short(value: Any) -> str:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return "{...}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def field_comments(cls: type) -> dict[str, str]:
    """Each field's comment in the class source: the comment ending its line, else the comment lines
    right above it."""
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return {}
    notes: dict[str, str] = {}
    above: list[str] = []
    line_names: dict[int, str] = {}
    for line_no, line in enumerate(source.splitlines(), start=1):
        m = re.match(r"\s+(\w+)\s*:", line)
        if m and not line.lstrip().startswith("#"):
            line_names[line_no] = m.group(1)
    comments: dict[int, str] = {}
    own_line: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = tok.string.lstrip("#").strip()
            if not tok.line[: tok.start[1]].strip():
                own_line.add(tok.start[0])
    for line_no in sorted(set(line_names) | own_line):
        if line_no in own_line:
            above.append(comments[line_no])
            continue
        name = line_names[line_no]
        if line_no in comments:
            notes[name] = comments[line_no]
        elif above:
            notes[name] = " ".join(above)
        above = []
    return notes
