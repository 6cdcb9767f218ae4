"""A child Python answering requests in order, its results coming back through shared memory.

For work asked for faster than a pipe would carry its results (the recorder's laser scans and LiDAR
sweeps, ``navlog.recorder.range_sensors``): requests are small, results large, and the caller must
never wait for the child while a result is due, nor the child for the caller.

``RingProcess`` (the caller's side) starts ``python -c CODE`` (``child.start_python``: a new
interpreter, never a fork of a process with threads, that imports only the handler's module and
this one) with the handler named by its module path, sends it ``setup`` bytes, then requests, and
gives each request's result as bytes, by ticket. ``serve`` (the child's side) builds the handler
from ``setup`` and passes it each request in order.

- Requests go through the child's input, framed as ``navlog.replay.workers.child`` frames them. A
  request the pipe has no room for yet (the child is still starting, or fell behind) waits in a queue
  in the caller's process (``child.RequestPipe``) and goes into the pipe as far as it has room each
  time the caller makes a request or looks for results, so the caller runs on meanwhile.
- Results come back through shared memory: a ring of ``ring_bytes``, in a memory file both
  processes map. The child writes each result into the ring, in request order and in one piece, and
  then a frame saying where it is (length, offset) to its output; the caller takes a result by
  copying it out of the ring when it looks for results (``ready``, ``result``, and while it waits
  for room in the request pipe), and stores the count of results taken in the shared memory's
  first 8 bytes, so the child never writes over a result not yet taken. A result that finds no room
  (the caller fell far behind, or a result larger than the ring) comes through the output pipe in
  its frame instead (``piped`` counts them). So the child never waits on the caller to write a
  result (no thread there has to take the GIL to read it), and the caller never waits on the child
  while a result is due: each side only waits for work to do.
- ``ending`` says in the shared memory's next 8 bytes that the caller only waits for the results
  still to come; the handler is told so with each request from then on (the recorder's casts on
  every core then). Without shared memory (no room for a memory file, e.g. ``ulimit -f 0``) every
  result comes through the pipe and the handler is never told.

The child runs in a process group of its own and ignores SIGINT (a Ctrl-C stops the caller, which
then ends the child), and it ends when its request pipe closes, also when the caller's process is
killed (the memory file goes with the last process that maps it); once it has served, it leaves at
once (``os._exit``: every result is written, pipe writes and shared memory need no flush, and
tearing down the handler's libraries would only delay the caller waiting for it). An exception in
the handler, or the child's death, is raised in the caller as ``NavlogError`` naming the child.
"""

from __future__ import annotations

import importlib
import mmap
import os
import select
import struct
import sys
import tempfile
import traceback
from collections import deque
from collections.abc import Callable, Mapping
from typing import BinaryIO

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.workers.child import (
    ERROR,
    FRAME,
    RequestPipe,
    end_process,
    ended,
    failed,
    read_frame,
    start_python,
)

__all__ = ["Handler", "RingProcess", "serve"]

_SETUP, _REQUEST = ord("S"), ord("Q")  # caller -> child
_IN_RING, _INLINE = ord("r"), ord("i")  # child -> caller: a result in the ring (where), or in the frame
_PLACE = struct.Struct("<IQ")  # an in-ring result's length and offset
# the shared file: the count of results the caller has taken (uint64, at offset 0: an aligned 8-byte store and
# load, never seen half-written), whether the caller only waits for the rest (uint64, at offset 8), then the ring
_RING_AT = 64
_COPIED, _ENDING = 0, 1  # the header's two words

Handler = Callable[[bytes, bool], bytes]  # (request, ending) -> result


def _shared_file(size: int) -> int | None:
    """A file descriptor of ``size`` bytes of memory to share with the child, gone with its last descriptor;
    None where there is no room for it (a file-size limit, ``ulimit -f``, counts it as a file)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("navlog-ring", os.MFD_CLOEXEC)
    else:  # pragma: no cover - every Linux has memfd_create; an unlinked temporary file elsewhere
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    try:
        os.ftruncate(fd, size)
    except OSError:
        os.close(fd)
        return None
    return fd


class RingProcess:
    """A child serving requests with the handler ``make(setup)``, ``make`` named ``"module:function"``;
    its results through a shared ring of ``ring_bytes`` (rounded up to whole pages) or its output pipe
    (module docstring). ``name`` names it in errors ("sensor worker"), ``run`` what stops with it
    ("recording"); ``env``: variables set in the child's environment. Raises ``OSError`` when no child
    can be started."""

    def __init__(
        self, name: str, make: str, setup: bytes, ring_bytes: int, *, run: str, env: Mapping[str, str] | None = None
    ) -> None:
        module, _, function = make.partition(":")
        ring = -(-max(0, ring_bytes) // mmap.PAGESIZE) * mmap.PAGESIZE
        shared = _shared_file(_RING_AT + ring)  # None: no ring, every result comes through the pipe
        self.name, self._run = name, run
        try:
            self._shared = mmap.mmap(-1, _RING_AT) if shared is None else mmap.mmap(shared, _RING_AT + ring)
            self.process = start_python(
                f"from navlog.replay.workers.ring import serve; serve({module!r}, {function!r})",
                args=(str(-1 if shared is None else shared),),
                pass_fds=() if shared is None else (shared,),
                env=env,
            )
        finally:
            if shared is not None:  # the child's copy (and the mapping) keep it now
                os.close(shared)
        assert self.process.stdin is not None and self.process.stdout is not None
        self._header = np.frombuffer(self._shared, np.uint64, 2)  # read by the child (module docstring)
        self._results = self.process.stdout
        self._pipe = RequestPipe(self.process.stdin.fileno())
        self._poll = select.poll()
        self._poll.register(self._results, select.POLLIN)
        self._next = 0  # ticket of the next request
        self._copied = 0  # results taken out of the ring or the pipe, in request order
        self._ready: dict[int, bytes] = {}  # taken, not yet asked for
        self.piped = 0  # results that came through the pipe, not the ring (it had no room for them)
        self._closed = False
        self._pipe.put(-1, FRAME.pack(_SETUP, len(setup)) + setup)
        self._flush(until=None)

    def request(self, data: bytes) -> int:
        """Send a request (queued while the pipe has no room: this never waits); its ticket."""
        if self._closed:
            raise self._died()
        ticket = self._next
        self._next += 1
        self._pipe.put(ticket, FRAME.pack(_REQUEST, len(data)) + data)  # one write: a request is a few kB
        self._flush(until=None)
        return ticket

    def ready(self, ticket: int) -> bool:
        """True when the result of request ``ticket`` has come (``result`` returns it without waiting)."""
        if self._closed:
            raise self._died()
        if self._pipe.unsent:
            self._flush(until=None)
        while ticket not in self._ready and self._poll.poll(0):
            self._take()
        return ticket in self._ready

    def result(self, ticket: int) -> bytes:
        """The result of request ``ticket``, waiting for it (each is given once)."""
        if ticket not in self._ready:
            if self._closed:
                raise self._died()
            if not self._copied <= ticket < self._next:
                raise ValueError(f"{self.name}: no result {ticket} is owed (not asked for, or given already)")
            self._flush(until=ticket)
            while ticket not in self._ready:
                self._take()
        return self._ready.pop(ticket)

    def ending(self) -> None:
        """The caller only waits for the results still to come: the handler is told so (module docstring)."""
        if not self._closed:
            self._header[_ENDING] = 1

    def close(self) -> None:
        """End the child: close its pipes (it exits on that, also when writing a result) and wait for it."""
        if self._closed:
            return
        self._closed = True
        end_process(self.process)
        self._ready.clear()
        self._pipe.unsent.clear()
        del self._header  # the last view of the mapping, which can then be closed
        self._shared.close()

    def _flush(self, until: int | None) -> None:
        """Put the queued requests into the pipe (``RequestPipe.flush``), taking results while it waits."""
        try:
            self._pipe.flush(until, self._results.fileno, self._take)
        except OSError:  # the child is gone (EPIPE)
            raise self._gone() from None

    def _take(self) -> None:
        """Take the next result (waiting for it) out of the ring or the pipe; ``NavlogError`` when the child
        failed or is gone."""
        frame = read_frame(self._results)
        if frame is None:
            raise self._died()
        code, body = frame
        if code == _IN_RING:
            size, at = _PLACE.unpack(body)
            data = self._shared[_RING_AT + at : _RING_AT + at + size]  # a copy: the child may reuse the place now
        elif code == _INLINE:
            data = bytes(body)
            self.piped += 1
        else:
            self.close()
            if code == ERROR:
                raise failed(self.name, self.process.pid, body)
            raise NavlogError(f"{self.name} (pid {self.process.pid}): unexpected reply {code}")
        self._ready[self._copied] = data
        self._copied += 1
        self._header[_COPIED] = self._copied

    def _gone(self) -> NavlogError:
        """The error of a child whose input broke: its own, with its traceback, when it failed on a request
        (it writes that and ends), else that it ended."""
        try:
            while True:  # what it wrote before it ended, up to the pipe's end
                self._take()
        except NavlogError as error:
            return error

    def _died(self) -> NavlogError:
        self.close()
        return ended(self.name, self.process, self._run)


class _Ring:
    """Where the child puts each result in the shared ring: in request order, each in one piece, never over
    a result the caller has not taken yet (those of tickets from ``copied`` on)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._live: deque[tuple[int, int, int]] = deque()  # (ticket, start, end) of results maybe not taken

    def place(self, ticket: int, n: int, copied: int) -> int | None:
        """The offset for result ``ticket`` of ``n`` bytes, or None when it does not fit now."""
        live = self._live
        while live and live[0][0] < copied:
            live.popleft()
        at: int | None
        if not live:
            at = 0 if n <= self.size else None
        else:
            tail, head = live[0][1], live[-1][2]
            if tail < head:  # the results in the ring do not wrap: after them, else from the start
                at = head if head + n <= self.size else (0 if n <= tail else None)
            else:  # they wrap: between the newest and the oldest
                at = head if head + n <= tail else None
        if at is not None:
            live.append((ticket, at, at + n))
        return at


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


def serve(module: str, function: str) -> None:
    """The child's program (``RingProcess``): build the handler with ``module.function(setup)`` from the
    first request, then answer requests in order until the request pipe closes, each result in the shared
    ring or, when it has no room, in the output pipe; an exception goes back as an error frame. Never
    returns: the process leaves at once (module docstring). The shared memory's descriptor is ``argv[1]``
    (-1: none)."""
    out = os.dup(1)  # the results' pipe; the standard output goes nowhere, so that no library prints into it
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.close(devnull)
    try:
        _serve(module, function, sys.stdin.buffer, out, int(sys.argv[1]))
    finally:
        os._exit(0)


def _serve(module: str, function: str, requests: BinaryIO, out: int, shm_fd: int) -> None:
    shared = bytearray(_RING_AT) if shm_fd < 0 else mmap.mmap(shm_fd, 0)  # no shared memory: no ring
    if shm_fd >= 0:
        os.close(shm_fd)
    header = np.frombuffer(shared, np.uint64, 2)  # results the caller has taken; whether it is ending
    ring = _Ring(len(shared) - _RING_AT)
    handle: Handler | None = None
    ticket = 0
    try:
        while (frame := read_frame(requests)) is not None:
            code, body = frame
            try:
                if code == _SETUP:
                    handle = getattr(importlib.import_module(module), function)(bytes(body))
                    continue
                if handle is None or code != _REQUEST:
                    raise ValueError(f"request {code} before the setup")
                result = handle(bytes(body), bool(header[_ENDING]))
            except Exception:
                error = traceback.format_exc().encode()
                _write_all(out, FRAME.pack(ERROR, len(error)) + error)
                return
            at = ring.place(ticket, len(result), int(header[_COPIED]))
            if at is None:
                _write_all(out, FRAME.pack(_INLINE, len(result)))
                _write_all(out, result)
            else:
                shared[_RING_AT + at : _RING_AT + at + len(result)] = result
                _write_all(out, FRAME.pack(_IN_RING, _PLACE.size) + _PLACE.pack(len(result), at))
            ticket += 1
    except OSError:  # BrokenPipeError and its kin: the caller is gone
        return
