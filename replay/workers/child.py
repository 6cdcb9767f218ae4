"""A child Python that answers requests over its pipes: what the replay's helper processes share.

A replay hands NumPy work to a child process where it can run beside the replay's thread (the
occupancy grid's scan updates, ``navlog.replay.workers.grid``; the 3D mapper's sweeps,
prepared and registered, ``navlog.replay.workers.odometry``). Both sides speak in frames:
one opcode byte, a little-endian uint32 length and the payload (arrays as raw bytes, parameters as
JSON: ``pack`` and ``unpack`` make and read such a payload); nothing is unpickled.

- ``ChildProcess`` (the parent's side) starts ``python -c CODE`` and sends requests; every request
  that is ``ask``-ed gets one reply, in order. Requests are written without blocking: while the pipe
  to the child is full, the replies that come are taken (kept for ``reply``), so a child writing a
  large reply and a parent writing a large request never wait for each other.
- ``serve`` (the child's side) says it is ready, then passes each request to a handler and writes
  the handler's reply, if any, until its input ends.

The child runs in a process group of its own and ignores SIGINT (a Ctrl-C stops the replay, which
closes the pipes) and exits when its input closes, so an interrupted or failed replay leaves no
process behind. An exception in the handler
comes back as ``NavlogError`` with its traceback; a child that died is named with its exit code.

Every child process of this package is started, written to, ended and named by the helpers here
(``ChildProcess`` and ``navlog.replay.workers.ring`` both use them): ``start_python`` (a new
interpreter, never a fork of a process with threads, in a process group of its own, SIGINT ignored
from its first statement, its pipes widened), ``RequestPipe`` (requests written without blocking,
what the pipe has no room for queued in this process, in order), ``end_process``, and ``failed`` /
``ended`` (the ``NavlogError`` naming a child that failed or died).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import select
import struct
import subprocess
import sys
import traceback
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import IO, Any, BinaryIO

import numpy as np

from navlog.errors import NavlogError

__all__ = [
    "ChildProcess",
    "RequestPipe",
    "end_process",
    "ended",
    "failed",
    "pack",
    "read_exactly",
    "read_frame",
    "run_python",
    "serve",
    "start_python",
    "unpack",
]

FRAME = struct.Struct("<BI")  # opcode, payload length
_META = struct.Struct("<I")  # the JSON part's length in ``pack``
READY, ERROR = ord("R"), ord("E")  # child -> parent, besides the replies
_PIPE_BYTES = 1 << 20  # what each pipe holds (Linux caps a pipe at pipe-max-size, 1 MiB by default)
_F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
_QUIET = "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "


def start_python(
    code: str, *, args: Sequence[str] = (), pass_fds: Sequence[int] = (), env: Mapping[str, str] | None = None
) -> subprocess.Popen:
    """``python -c code *args``, with pipes to its standard input and output (unbuffered, each holding
    ``_PIPE_BYTES`` where Linux allows it), in a process group of its own, ignoring SIGINT from its first
    statement; ``pass_fds`` stay open in it, ``env`` is set in its environment beside this process's.
    Raises ``OSError`` when no child can be started."""
    # a process group of its own: a Ctrl-C in the terminal reaches the caller only, which ends the child by
    # closing its pipes; in the caller's group, a child still starting (before its code ignores SIGINT)
    # died with "Fatal Python error" and a traceback on the terminal
    process = subprocess.Popen(
        [sys.executable, "-c", _QUIET + code, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        bufsize=0,
        pass_fds=tuple(pass_fds),
        process_group=0,
        env=None if env is None else {**os.environ, **env},
    )
    for stream in (process.stdin, process.stdout):
        try:
            assert stream is not None
            fcntl.fcntl(stream.fileno(), _F_SETPIPE_SZ, _PIPE_BYTES)
        except OSError:  # not allowed here: the sides then wait sooner for each other
            pass
    return process


# held to a limit in the child: never above the hard limit it inherits
_CAP = """import resource as _r
def _cap(kind, value):
    hard = _r.getrlimit(kind)[1]
    _r.setrlimit(kind, (value if hard == _r.RLIM_INFINITY else min(value, hard), hard))
"""


def run_python(
    code: str, *, args: Sequence[str] = (), timeout: float, cpu_seconds: int | None = None, memory: int | None = None
) -> tuple[bytes, int]:
    """``python -c code *args`` (``start_python``, its input closed at once) run to its end: what it wrote to
    its output and its exit code; killed once it outlives ``timeout`` seconds of wall time (its output then is
    empty and its code negative: the signal). With ``cpu_seconds`` and ``memory`` (bytes of address space) the
    child is held to them from its first statement (never above the limits this process already has; a limit
    not given is left as it is): past the CPU time it is killed by a signal, past the memory its allocations
    fail (``MemoryError``). Raises ``OSError`` when no child can be started."""
    limits = {"RLIMIT_CPU": cpu_seconds, "RLIMIT_AS": memory}
    caps = [f"_cap(_r.{kind}, {int(value)})" for kind, value in limits.items() if value is not None]
    if caps:
        code = _CAP + "; ".join(caps) + "; del _r, _cap\n" + code
    process = start_python(code, args=args)
    try:
        out, _ = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        out = b""
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        for stream in (process.stdin, process.stdout):
            if stream is not None and not stream.closed:
                stream.close()
    return out, process.returncode


def end_process(process: subprocess.Popen) -> None:
    """Close the pipes to and from ``process`` (a child started by ``start_python`` exits on that, also
    while writing to this process) and wait for it; kill it if it has not ended within 10 s."""
    for stream in (process.stdin, process.stdout):
        if stream is not None:
            try:
                stream.close()
            except OSError:
                pass
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def failed(name: str, pid: int | str, traceback_text: bytes | bytearray) -> NavlogError:
    """The error of child ``name`` that failed, with the traceback it sent."""
    return NavlogError(f"{name} (pid {pid}) failed:\n{traceback_text.decode(errors='replace')}")


def ended(name: str, process: subprocess.Popen | None, run: str) -> NavlogError:
    """The error of child ``name`` that ended before its work was done (``process`` waited for: its exit
    code is known; None when unknown); ``run``: what stops with it ("replay", "recording")."""
    pid, code = (process.pid, process.returncode) if process is not None else ("?", "?")
    return NavlogError(f"{name} (pid {pid}) ended unexpectedly (exit code {code}); the {run} stops here")


class RequestPipe:
    """Requests to a child, written to its input without blocking: what the pipe has no room for waits here,
    in order, and goes in with later writes (``flush``)."""

    def __init__(self, fd: int) -> None:
        os.set_blocking(fd, False)  # a write takes what the pipe has room for
        self.fd = fd
        self.unsent: deque[tuple[int, memoryview]] = deque()  # (request number, bytes not yet written)

    def put(self, number: int, *parts: bytes) -> None:
        """Queue the parts of request ``number`` (numbers increase; nothing is written yet)."""
        self.unsent.extend((number, memoryview(part)) for part in parts if part)

    def flush(self, until: int | None, replies: Callable[[], int | None], take: Callable[[], None]) -> None:
        """Write the queued requests while the pipe has room; with ``until``, wait for room until request
        ``until`` is written. While it waits, ``replies()`` names the descriptor the child's replies come
        from (None: none is owed) and ``take()`` is called whenever it is readable: a child writing a reply
        and this process writing a request never wait for each other. ``OSError`` (EPIPE): the child is gone."""
        unsent = self.unsent
        while unsent:
            number, view = unsent[0]
            try:
                written = os.write(self.fd, view)
            except BlockingIOError:  # the pipe is full
                if until is None or number > until:
                    return
                listen = replies()
                readable, _, _ = select.select([] if listen is None else [listen], [self.fd], [])
                if readable:
                    take()
                continue
            if written < len(view):
                unsent[0] = (number, view[written:])
            else:
                unsent.popleft()


class ChildProcess:
    """``python -c code`` (whose code calls ``serve``), and the requests sent to it (module docstring).
    Raises ``OSError`` when no child can be started."""

    def __init__(self, name: str, code: str) -> None:
        self.name = name  # how errors name it: "occupancy grid process"
        self.process: subprocess.Popen | None = start_python(code)
        self.owed = 0  # replies asked for and not yet given by ``reply``
        self._early: deque[tuple[int, bytearray]] = deque()  # replies read while sending
        self._started = False
        self._sent = 0  # requests sent
        assert self.process.stdin is not None
        self._pipe = RequestPipe(self.process.stdin.fileno())  # see ``send``

    @property
    def pid(self) -> int | None:
        return self.process.pid if self.process is not None else None

    def started(self) -> bool:
        """True once the child has said it is ready (without waiting); False while it starts, and after
        it ended before it was ready (it is closed then)."""
        if self._started:
            return True
        process = self.process
        if process is None or process.stdout is None or not select.select([process.stdout], [], [], 0)[0]:
            return False
        try:
            frame = self._take_frame()
        except NavlogError:
            return False
        if frame is not None:
            raise NavlogError(f"{self.name} (pid {process.pid}): unexpected reply {frame[0]} at start-up")
        return True

    def send(self, op: int, payload: bytes) -> None:
        """Send request ``op`` (no reply expected); returns once it is in the pipe. While the pipe is full,
        the replies that come are taken (kept for ``reply``)."""
        if self.process is None:
            raise self._died()
        number = self._sent
        self._sent += 1
        self._pipe.put(number, FRAME.pack(op, len(payload)), payload)
        try:
            self._pipe.flush(number, self._replies_owed, self._take_early)
        except OSError:  # the child is gone (EPIPE)
            raise self._gone() from None

    def _replies_owed(self) -> int | None:
        """The descriptor of the child's replies while one is owed and not yet read; else None."""
        out = self.process.stdout if self.process is not None else None
        return out.fileno() if out is not None and self.owed > len(self._early) else None

    def _take_early(self) -> None:
        if (frame := self._take_frame()) is not None:
            self._early.append(frame)

    def ask(self, op: int, payload: bytes = b"") -> None:
        """Send request ``op``, whose reply a later ``reply`` gives (in the order asked)."""
        self.send(op, payload)
        self.owed += 1

    def reply_ready(self) -> bool:
        """True when the next owed reply can be taken without waiting."""
        out = self.process.stdout if self.process is not None else None
        while not self._early and self.owed and out is not None and select.select([out], [], [], 0)[0]:
            self._take_early()
        return bool(self._early)

    def reply(self) -> bytearray:
        """The payload of the next owed reply, in the order asked (waits for it)."""
        if not self.owed:
            raise RuntimeError(f"{self.name}: no reply is owed")
        if self._early:
            body = self._early.popleft()[1]
        else:
            while (frame := self._take_frame()) is None:
                pass
            body = frame[1]
        self.owed -= 1
        return body

    def close(self) -> None:
        """End the child: close its input (it exits on that) and wait for it."""
        process, self.process = self.process, None
        if process is not None:
            end_process(process)

    def _take_frame(self) -> tuple[int, bytearray] | None:
        """The next frame from the child; None for its "ready" (which comes first)."""
        frame = self._read_frame()
        if frame[0] == READY and not self._started:
            self._started = True
            return None
        return frame

    def _read_frame(self) -> tuple[int, bytearray]:
        process = self.process
        if process is None or process.stdout is None:
            raise self._died()
        frame = read_frame(process.stdout)
        if frame is None:
            raise self._died()
        code, body = frame
        if code == ERROR:
            self.close()
            raise failed(self.name, process.pid, body)
        return code, body

    def _gone(self) -> NavlogError:
        """The error of a child whose input broke: its own, with its traceback, when it failed on a request
        (it writes that and ends), else that it ended."""
        try:
            while True:  # what it wrote before it ended, up to the pipe's end
                self._read_frame()
        except NavlogError as error:
            return error

    def _died(self) -> NavlogError:
        process = self.process
        self.close()
        return ended(self.name, process, "replay")


def pack(meta: Any, arrays: Sequence[np.ndarray | None] = ()) -> bytes:
    """A payload of JSON (``meta``) and arrays (None allowed): the JSON names each array's dtype and
    shape, the arrays follow as raw bytes, in order."""
    shapes = [None if a is None else [a.dtype.str, list(a.shape)] for a in arrays]
    head = json.dumps([meta, shapes]).encode()
    parts = [_META.pack(len(head)), head]
    parts += [np.ascontiguousarray(a).tobytes() for a in arrays if a is not None]
    return b"".join(parts)


def unpack(body: bytes | bytearray) -> tuple[Any, list[np.ndarray | None]]:
    """(meta, arrays) of a ``pack`` payload; the arrays are views of ``body`` (read-only for bytes)."""
    (n,) = _META.unpack_from(body)
    meta, shapes = json.loads(bytes(body[_META.size : _META.size + n]))
    at = _META.size + n
    arrays: list[np.ndarray | None] = []
    for spec in shapes:
        if spec is None:
            arrays.append(None)
            continue
        dtype, shape = np.dtype(spec[0]), tuple(spec[1])
        count = math.prod(shape)
        arrays.append(np.frombuffer(body, dtype, count, at).reshape(shape))
        at += count * dtype.itemsize
    return meta, arrays


def read_exactly(stream: IO[bytes] | BinaryIO, n: int) -> bytearray | None:
    """Exactly ``n`` bytes from ``stream`` (read into one buffer); None at its end."""
    buf = bytearray(n)
    view, got = memoryview(buf), 0
    while got < n:
        k = stream.readinto(view[got:])  # type: ignore[union-attr]
        if not k:
            return None
        got += k
    return buf


def read_frame(stream: IO[bytes] | BinaryIO) -> tuple[int, bytearray] | None:
    """The next frame from ``stream``: its opcode and payload; None at the stream's end (also mid-frame)."""
    head = read_exactly(stream, FRAME.size)
    if head is None:
        return None
    code, n = FRAME.unpack(head)
    body = read_exactly(stream, n)
    return None if body is None else (code, body)


Handler = Callable[[int, bytes | bytearray], "tuple[int, bytes] | None"]


def serve(handle: Handler, stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
    """The child's loop: say it is ready, then give each request to ``handle(op, payload)`` and write
    the reply it returns (None: no reply) until the input ends; an exception goes back as an error
    reply and ends the loop. A parent gone (its pipes closed, e.g. an interrupted replay) ends it quietly."""
    inp = stdin or sys.stdin.buffer
    out = stdout or open(sys.stdout.fileno(), "wb", buffering=0, closefd=False)  # nothing held back at exit
    try:
        out.write(FRAME.pack(READY, 0))
        out.flush()
        while (frame := read_frame(inp)) is not None:
            code, body = frame
            try:
                reply = handle(code, body)
            except Exception:
                reply = (ERROR, traceback.format_exc().encode())
            if reply is not None:
                out.write(FRAME.pack(reply[0], len(reply[1])) + reply[1])
                out.flush()
                if reply[0] == ERROR:
                    return
    except OSError:  # BrokenPipeError and its kin: nobody is listening any more
        return
