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
