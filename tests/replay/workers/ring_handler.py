"""A handler for ``RingProcess`` in the tests: a request names a result's size and seed, the result is
that many bytes drawn from the seed, after a byte saying whether the caller was ending."""

from __future__ import annotations

import os
import struct
from collections.abc import Callable

import numpy as np

REQUEST = struct.Struct("<iQ")  # size, seed
FAIL, PRINT = -1, -2  # sizes: raise an error; print to the standard output, then give 100 bytes


def request(size: int, seed: int, pad: int = 0) -> bytes:
    """A request of ``REQUEST`` and ``pad`` bytes more (to fill the request pipe)."""
    return REQUEST.pack(size, seed) + bytes(pad)


def expected(size: int, seed: int, ending: bool = False) -> bytes:
    return bytes([ending]) + np.random.default_rng(seed).bytes(size - 1)


def make(setup: bytes) -> Callable[[bytes, bool], bytes]:
    if setup == b"fail":
        raise ValueError("no handler for this setup")

    def handle(data: bytes, ending: bool) -> bytes:
        size, seed = REQUEST.unpack_from(data)
        if size == FAIL:
            raise ValueError(f"request {seed} fails")
        if size == PRINT:  # a library printing: it must not reach the results
            os.write(1, b"\x00" * 64)
            print("printed", flush=True)
            size = 100
        return expected(size, seed, ending)

    return handle
