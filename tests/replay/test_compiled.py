"""``compile_together``: numba-compiled functions that call each other compiled."""

from __future__ import annotations

import numpy as np

from navlog.replay.compiled import compile_together


def _half(v):
    return v // 2


def halves_sum(a):
    total = 0
    for v in a:
        total += _half(v)
    return total


def test_functions_compile_together_and_call_each_other_compiled():
    compiled = compile_together(globals(), (_half, halves_sum))
    assert set(compiled) == {"_half", "halves_sum"}
    a = np.arange(-5, 12, dtype=np.int64)
    assert compiled["halves_sum"](a) == halves_sum(a) == int((a // 2).sum())
    # a numba dispatcher, run in nopython mode: there it can call only a compiled ``_half``
    assert compiled["halves_sum"].nopython_signatures
    assert compiled["halves_sum"].py_func is not halves_sum  # a copy bound to the compiled scope
    assert compiled["halves_sum"].py_func.__globals__["_half"] is compiled["_half"]
