"""numba for navlog's hot loops: compiled together, cached on disk, plain Python where numba is missing.

``compile_together(namespace, functions)`` compiles plain-Python functions on NumPy arrays and
scalars with ``numba.njit`` in one scope of their own (a copy of ``namespace``, the defining module's
globals), so a compiled function that calls another of them calls the compiled one. The machine code
is cached on disk beside the module (``cache=True``); where no cache directory is writable the
functions are compiled in this process only. It returns the compiled functions by name, or None where
numba is not installed: the callers then run the same functions uncompiled, or NumPy code that gives
the same bits.
"""

from __future__ import annotations

import types
import warnings
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["compile_together"]


def compile_together(namespace: dict[str, Any], functions: Iterable[Callable[..., Any]]) -> dict[str, Any] | None:
    """The ``functions`` compiled by numba in one scope (see the module docstring), by name; None without numba."""
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a dependency; a platform without its wheels runs plain Python
        return None

    def jit(fn: Callable[..., Any]) -> Any:
        try:
            return numba.njit(cache=True)(fn)
        except RuntimeError:  # no writable cache directory: compile in this process only
            return numba.njit(cache=False)(fn)

    functions = list(functions)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=numba.NumbaWarning)
        scope = dict(namespace)
        for fn in functions:
            plain = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
            scope[fn.__name__] = jit(plain)
    return {fn.__name__: scope[fn.__name__] for fn in functions}
