"""The type store a log reader decodes with: schema text from the file -> message types.

Every reader starts with the shared base store (``messages.typestore()``: the ROS 2 types and
navlog's own), which nothing ever registers into. A log whose schemas define a type the base store
lacks gets a store of its own — a new base store (``messages.new_typestore()``) with the log's
types registered — so two logs that define the same type name differently each decode with their
own definition, and opening a log changes nothing for the next one.
"""

from __future__ import annotations

from typing import Any

from rosbags.typesys import get_types_from_msg

from navlog.replay import messages

_SECTION = "=" * 80 + "\n"


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


class LogTypestore:
    """The type store of one reader: the shared base store until a schema brings a type it lacks.

    ``store`` starts a reader off with a store of its own that it already has (a bag reader's).
    """

    def __init__(self, store: Any = None) -> None:
        self.own = store is not None  # True once this reader has a store of its own
        self.store = store if store is not None else messages.typestore()

    def add_schema(self, typename: str, text: str) -> bool:
        """Make ``typename`` decodable from its schema text; False if the text cannot be parsed.

        A type the store already has keeps the definition it has.
        """
        if typename in self.store.types:
            return True
        try:
            types = types_from_schema(typename, text)
            if not self.own:
                self.store = messages.new_typestore()
                self.own = True
            self.store.register(types)
            return typename in self.store.types
        except Exception:
            return False
