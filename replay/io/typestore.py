"""The type store a log reader decodes with: schema text from the file -> message types.

Every reader starts with the shared base store (``messages.typestore()``: the ROS 2 types and
navlog's own), which nothing ever registers into. A log whose schemas define a type the base store
lacks gets a store of its own — a new base store (``messages.new_typestore()``) with the log's
types registered — so two logs that define the same type name differently each decode with their
own definition, and opening a log changes nothing for the next one.

A schema is evidence, not an order: its text is bounded before it is parsed (``MAX_SCHEMA_BYTES``,
``MAX_SCHEMA_FIELDS``, and ``MAX_LOG_SCHEMA_FIELDS`` for all the schemas of one log: the parser's time
grows faster than the number of fields, and a crafted 300,000-field schema would take minutes), a
type that contains itself, directly or through others, is refused (decoding it would never end), and so
are types nested deeper than ``MAX_TYPE_DEPTH`` (the code that hashes and decodes them recurses per level). A
refused schema leaves its type unknown, so its topics are counted skips; ``LogTypestore.refused`` holds
the reason, naming the type.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from rosbags.typesys import get_types_from_msg
from rosbags.typesys.base import Nodetype

from navlog.replay import messages

_SECTION = "=" * 80 + "\n"

# The largest definitions in the ROS 2 message sets, with every section they depend on, hold a few hundred
# fields in a few tens of KiB of text (comments included); parsing 4096 fields takes under a second.
MAX_SCHEMA_BYTES = 1 << 20
MAX_SCHEMA_FIELDS = 4096
MAX_LOG_SCHEMA_FIELDS = 16384  # all the schemas one log's reader parses
# ROS 2 messages nest a handful of types deep (nav_msgs/Odometry -> PoseWithCovariance -> Pose -> Point);
# rosbags' hashing, definition and (de)serialization code recurses once or more per level.
MAX_TYPE_DEPTH = 64


def types_from_schema(typename: str, text: str) -> dict[str, Any]:
    """The types a ``ros2msg`` schema defines: its root type and one per ``MSG: pkg/Name`` section."""
    sections = text.split(_SECTION)
    types: dict[str, Any] = {}
    types.update(get_types_from_msg(sections[0], typename))
    for sec in sections[1:]:
        head, _, body = sec.partition("\n")
        if head.startswith("MSG: "):
            name = head[5:].strip()
            if "/msg/" not in name:
                pkg, _, base = name.partition("/")
                name = f"{pkg}/msg/{base}"
            types.update(get_types_from_msg(body, name))
    return types


def schema_fields(text: str) -> int:
    """The field and constant lines of a schema's text (its size as the parser sees it)."""
    return sum(1 for line in text.splitlines() if line.strip() and not line.lstrip().startswith(("#", "=", "MSG:")))


def _names(field_type: Any) -> Iterator[str]:
    """The message type names a parsed field type refers to (through arrays and sequences)."""
    kind, detail = field_type
    if kind == Nodetype.NAME:
        yield detail
    elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        yield from _names(detail[0])


def type_cycle(types: dict[str, Any], first: str = "") -> list[str]:
    """A chain of types that contains itself (``[A, B, A]``: A holds a B, which holds an A), or []; the
    search starts from ``first``."""
    edges = {name: [n for _, ft in fields for n in _names(ft) if n in types] for name, (_, fields) in types.items()}
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    for root in sorted(edges, key=lambda name: (name != first, name)):
        if state.get(root):
            continue
        path, stack = [root], [iter(edges[root])]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            elif not state.get(nxt):
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(edges[nxt]))
    return []


def type_depth(types: dict[str, Any], root: str, known: dict[str, int] | None = None) -> int:
    """How many message types deep ``root`` nests (1: only built-in fields), through the types of ``types``
    (acyclic: ``type_cycle`` found none) and those of ``known`` (depths of types already registered)."""
    return type_depths(types, known).get(root, 1)


def type_depths(types: dict[str, Any], known: dict[str, int] | None = None) -> dict[str, int]:
    """The depth (``type_depth``) of every type of ``types``; a field of a type in ``known`` counts that
    type's known depth."""
    known = known or {}
    edges = {
        name: [n for _, ft in fields for n in _names(ft) if n in types or n in known]
        for name, (_, fields) in types.items()
    }
    depth: dict[str, int] = {n: d for n, d in known.items() if n not in edges}
    for root in edges:
        stack = [root] if root not in depth else []
        while stack:  # depth first without recursion: a type's depth once all it holds have theirs
            name = stack[-1]
            todo = [n for n in edges[name] if n not in depth]
            if todo:
                stack.extend(todo)
            else:
                stack.pop()
                depth[name] = 1 + max((depth[n] for n in edges[name]), default=0)
    return {n: depth[n] for n in edges}


class LogTypestore:
    """The type store of one reader: the shared base store until a schema brings a type it lacks.

    ``store`` starts a reader off with a store of its own that it already has (a bag reader's).
    """

    def __init__(self, store: Any = None) -> None:
        self.own = store is not None  # True once this reader has a store of its own
        self.store = store if store is not None else messages.typestore()
        self.refused: dict[str, str] = {}  # type name -> why its schema was refused
        self.fields_parsed = 0  # toward MAX_LOG_SCHEMA_FIELDS
        self.depths: dict[str, int] = {}  # how deep each type of an accepted schema nests (``type_depth``)

    def add_schema(self, typename: str, text: str) -> bool:
        """Make ``typename`` decodable from its schema text; False if the text cannot be parsed or is
        refused (``refused`` says why).

        A type the store already has keeps the definition it has.
        """
        if typename in self.store.types:
            return True
        try:
            types = self.vetted(typename, text, lambda body, name: types_from_schema(name, body))
            if types is None:
                return False
            if not self.own:
                self.store = messages.new_typestore()
                self.own = True
            self.store.register(types)
            return typename in self.store.types
        except Exception:
            return False

    def vetted(self, typename: str, text: str, parse: Callable[[str, str], dict[str, Any]]) -> dict[str, Any] | None:
        """The types ``parse(text, typename)`` defines, or None when the schema is refused (too large, or a
        type in it contains itself; ``refused`` says why). Parse errors propagate."""
        if typename in self.refused:
            return None
        why = self._too_large(text)
        types = {} if why else parse(text, typename)
        cycle = type_cycle(types, typename)
        if cycle:
            why = f"recursive type ({' holds '.join(cycle)})"
        else:
            depths = type_depths(types, self.depths)
            if (depth := max(depths.values(), default=1)) > MAX_TYPE_DEPTH:
                why = f"types nested {depth} deep, more than {MAX_TYPE_DEPTH}"
        if why:
            self.refused[typename] = f"schema of {typename} refused: {why}"
            return None
        self.depths.update(depths)
        return types

    def _too_large(self, text: str) -> str:
        """Why a schema's text is too large to parse (the module docstring), or ''."""
        if len(text) > MAX_SCHEMA_BYTES:
            return f"{len(text)} bytes of text, more than {MAX_SCHEMA_BYTES}"
        n = schema_fields(text)
        if n > MAX_SCHEMA_FIELDS:
            return f"{n} fields, more than {MAX_SCHEMA_FIELDS}"
        if self.fields_parsed + n > MAX_LOG_SCHEMA_FIELDS:
            return f"the log's schemas hold more than {MAX_LOG_SCHEMA_FIELDS} fields in all"
        self.fields_parsed += n
        return ""
