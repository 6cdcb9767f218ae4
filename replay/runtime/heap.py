"""The C heap of a long replay: a fixed threshold for glibc's mapped blocks, so the peak stays flat.

glibc's malloc gives a block above ``M_MMAP_THRESHOLD`` a mapping of its own, returned to the system
when freed, and takes smaller ones from its heap. By default the threshold follows the largest mapped
block freed so far (up to 32 MiB): once a replay has freed its first arrays of a few megabytes (the
3D global map's sorted store is rewritten at every sweep), every later block below that size comes
from the heap, where sweep-sized arrays and the small_gicp maps' buffers, freed and taken again in a
different order, leave gaps the heap cannot give back. The resident size then climbs over a long log:
a full mapping replay of a 10-minute patrol log peaked 39 % above that of its first minute.

``steady_heap`` sets the threshold once, which also stops glibc from moving it: blocks up to 4 MiB
(a 3D sweep's arrays, a 2D SLAM lookup grid's, taken and freed at every sweep or scan) come from the
heap, larger ones have mappings of their own. It also lets the heap keep up to 64 MiB free at its top
(``M_TRIM_THRESHOLD``, which a fixed mmap threshold would otherwise leave at 128 KiB): a block freed
there is reused by the next one instead of being handed back and faulted in anew, page by page.
``HeapTrim`` bounds what the heap keeps over time. With the threshold at 512 KiB, every SLAM lookup
grid's arrays were mapped and faulted in anew (the figures: the performance page). Elsewhere than
glibc (no ``mallopt``) it does nothing.

The heap's free pages stay resident too: a block freed between blocks still in use is kept for the
heap's next use, and over a long replay the free space among them grows (a 10-minute patrol log's
full mapping replay: 2 MiB of free heap after its first minute, 24 MiB at its end, while the blocks in
use stayed at 17-19 MiB). ``HeapTrim`` hands those pages back to the system (glibc's ``malloc_trim``,
which releases whole free pages anywhere in every arena), at most every ``period_s`` of wall time: a
replay calls it between steps, so the resident size follows what is in use. A call takes about
0.6 ms; elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import sys
import time
from collections.abc import Callable

__all__ = ["STEADY_MMAP_THRESHOLD", "HeapTrim", "steady_heap"]

STEADY_MMAP_THRESHOLD = 4 << 20
STEADY_TRIM_THRESHOLD = 64 << 20
_M_MMAP_THRESHOLD = -3  # glibc's malloc.h
_M_TRIM_THRESHOLD = -1
_done = False


def steady_heap(threshold: int = STEADY_MMAP_THRESHOLD, trim: int = STEADY_TRIM_THRESHOLD) -> bool:
    """Fix glibc's mmap threshold at ``threshold`` bytes and its trim threshold at ``trim`` bytes for this
    process (once); True where they were set."""
    global _done
    if _done:
        return True
    mallopt = _libc("mallopt", (ctypes.c_int, ctypes.c_int))
    if mallopt is None:
        return False
    _done = mallopt(_M_MMAP_THRESHOLD, threshold) == 1 and mallopt(_M_TRIM_THRESHOLD, trim) == 1
    return _done


def _libc(name: str, argtypes: tuple) -> Callable[..., int] | None:
    """The function ``name`` (returning int) of the process's own C library, on Linux; None elsewhere
    or where the library has no such function."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        fn = getattr(ctypes.CDLL(None), name)
    except (OSError, AttributeError):
        return None
    fn.argtypes, fn.restype = argtypes, ctypes.c_int
    return fn


class HeapTrim:
    """Free heap pages handed back to the system, at most every ``period_s`` of wall time (module docstring)."""

    def __init__(self, period_s: float = 0.25) -> None:
        self.period_s = period_s
        self.calls = 0
        self._trim = _libc("malloc_trim", (ctypes.c_size_t,))
        self._next = time.perf_counter() + period_s

    def __call__(self) -> None:
        """Trim, if ``period_s`` has passed since the last time."""
        if self._trim is None or (now := time.perf_counter()) < self._next:
            return
        self._trim(0)
        self.calls += 1
        self._next = now + self.period_s
