"""The JSON text of every report, manifest and summary navlog writes: never NaN or Infinity.

RFC 8259 has no token for them; Python's ``json`` writes ``NaN`` and ``Infinity`` by default, which
``jq``, JavaScript and most other parsers refuse. ``dumps`` writes each non-finite float as ``null``
and says why: a top-level object gains ``non_finite_values``, the path of each such value (``a.b[2]``)
and what it was (``NaN``, ``+inf``, ``-inf``). A document of finite values is written exactly as
``json.dumps`` writes it.
"""

from __future__ import annotations

import json
import math
from typing import Any

NON_FINITE_KEY = "non_finite_values"


def finite_values(value: Any) -> tuple[Any, dict[str, str]]:
    """``value`` with each non-finite float replaced by None, and {path: "NaN" | "+inf" | "-inf"} of them."""
    notes: dict[str, str] = {}

    def walk(v: Any, path: str) -> Any:
        if isinstance(v, float):  # (numpy's float64 too)
            if math.isfinite(v):
                return v
            notes[path or "(document)"] = "NaN" if math.isnan(v) else ("+inf" if v > 0 else "-inf")
            return None
        if isinstance(v, dict):
            return {k: walk(x, f"{path}.{k}" if path else str(k)) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [walk(x, f"{path}[{i}]") for i, x in enumerate(v)]
        return v

    return walk(value, ""), notes


def dumps(value: Any, **options: Any) -> str:
    """``json.dumps(value, **options)`` with non-finite floats as null, named under ``non_finite_values``."""
    clean, notes = finite_values(value)
    if notes and isinstance(clean, dict):
        clean[NON_FINITE_KEY] = {path: f"{what}, written as null" for path, what in notes.items()}
    return json.dumps(clean, allow_nan=False, **options)
