"""numba for navlog's hot loops: plain-Python functions compiled together, cached on disk.

``compile_together(namespace, functions)`` compiles plain-Python functions on NumPy arrays and
scalars with ``numba.njit`` in one scope of their own (a copy of ``namespace``, the defining module's
globals), so a compiled function that calls another of them calls the compiled one. The machine code
is cached on disk beside the module (``cache=True``); where no cache directory is writable the
functions are compiled in this process only. numba is a dependency of navlog; it is imported on the
first call, so a module that only defines kernels stays cheap to import.
"""

from __future__ import annotations

import types
import warnings
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["compile_together"]


def compile_together(namespace: dict[str, Any], functions: Iterable[Callable[..., Any]]) -> dict[str, Any]:
    """The ``functions`` compiled by numba in one scope (see the module docstring), by name."""
    import numba

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
