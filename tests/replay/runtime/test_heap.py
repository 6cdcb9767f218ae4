"""The fixed mmap threshold of a replay's process: set once, and what it changes (in a fresh process)."""

from __future__ import annotations

import subprocess
import sys

import pytest

PROBE = """
import resource, sys
from navlog.replay.runtime.heap import steady_heap
mode, size, first = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if mode == "steady":
    assert steady_heap() and steady_heap()  # once; the second call says it is set
if first:
    big = bytearray(first)  # a large block, freed: glibc's own threshold rises to its size
    del big
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(40):
    block = bytearray(size)
    block[::4096] = b"x" * len(block[::4096])  # touch every page
    del block
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def faults(mode: str, size: int, first: int = 0) -> int:
    out = subprocess.run(
        [sys.executable, "-c", PROBE, mode, str(size), str(first)], capture_output=True, text=True, check=True
    )
    return int(out.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_blocks_below_the_threshold_come_from_the_heap_and_larger_ones_get_mappings_of_their_own():
    """Forty 2 MB blocks (a SLAM lookup grid's arrays) taken and freed with the threshold fixed at 4 MiB
    and the heap's top kept: from the heap (a few hundred faults, where a threshold of 512 kB mapped
    each anew: 40 x 489 pages). Forty 6 MB blocks after an 8 MB one was freed: from the heap by default
    (glibc's own threshold rose to 8 MB), each mapped anew with the threshold fixed (40 x 1465 pages),
    so that blocks above it never linger in the heap."""
    assert faults("steady", 2_000_000) < 2000
    assert faults("default", 6_000_000, 8 << 20) < 2000
    assert faults("steady", 6_000_000, 8 << 20) >= 40 * 1400


TRIM_PROBE = """
import sys
from navlog.replay.runtime.heap import HeapTrim
def rss_kib():
    return next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmRSS"))
trim = HeapTrim(period_s=float(sys.argv[1]))
blocks = [bytearray(b"x" * 4000) for _ in range(20_000)]  # 80 MB from the heap, every page touched
kept = blocks[::16]  # one block in 16 stays: the heap cannot shrink from its top
del blocks
before = rss_kib()
trim()
trim()
print(before - rss_kib(), trim.calls)
"""


def trimmed(period_s: float) -> tuple[int, int]:
    out = subprocess.run([sys.executable, "-c", TRIM_PROBE, str(period_s)], capture_output=True, text=True, check=True)
    freed, calls = out.stdout.split()
    return int(freed), int(calls)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim")
def test_free_pages_among_blocks_in_use_go_back_to_the_system_at_most_once_a_period():
    """75 MB freed among blocks still in use stay resident until trimmed; then most of it goes back
    (whole free pages between the kept blocks: 15 of every 16). Within one period, one trim."""
    freed, calls = trimmed(0.0)
    assert calls == 2 and freed > 50_000  # KiB
    freed, calls = trimmed(3600.0)
    assert calls == 0 and freed < 5_000
