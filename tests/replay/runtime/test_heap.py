"""The fixed mmap threshold of a replay's process: set once, and what it changes (in a fresh process)."""

from __future__ import annotations

import subprocess
import sys

import pytest

PROBE = """
import resource, sys
from navlog.replay.runtime.heap import steady_heap
if sys.argv[1] == "steady":
    assert steady_heap() and steady_heap()  # once; the second call says it is set
big = bytearray(8 << 20)  # a large block, freed: glibc's own threshold would rise past 600 kB
del big
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(40):
    block = bytearray(600_000)
    block[::4096] = b"x" * len(block[::4096])  # touch every page
    del block
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def faults(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True, check=True)
    return int(out.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_blocks_above_the_threshold_get_mappings_of_their_own_after_a_large_one_is_freed():
    """Forty 600 kB blocks taken and freed after an 8 MB one: from the heap by default (a few page
    faults: the heap's pages are reused), each in a mapping of its own with the threshold fixed at
    512 kB (every page faulted in anew: 40 x 147 pages)."""
    assert faults("default") < 1000
    assert faults("steady") >= 40 * 140


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
