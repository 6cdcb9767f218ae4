"""The child-process plumbing both workers share: the child's loop on in-memory streams (ready, replies,
an error ending it, a parent gone), and a parent that asks a real child in order."""

from __future__ import annotations

import io
import os

import pytest

from navlog.errors import NavlogError
from navlog.replay.workers.child import ERROR, FRAME, READY, ChildProcess, read_exactly, serve


def frames(data: bytes) -> list[tuple[int, bytes]]:
    out, stream = [], io.BytesIO(data)
    while (head := read_exactly(stream, FRAME.size)) is not None:
        code, n = FRAME.unpack(head)
        out.append((code, bytes(read_exactly(stream, n) or b"")))
    return out


def request(op: str, payload: bytes = b"") -> bytes:
    return FRAME.pack(ord(op), len(payload)) + payload


def test_the_child_says_it_is_ready_then_answers_each_request():
    def handle(code: int, body: bytearray) -> tuple[int, bytes] | None:
        return None if code == ord("N") else (code, bytes(body[::-1]))

    out = io.BytesIO()
    serve(handle, io.BytesIO(request("A", b"abc") + request("N", b"x") + request("B", b"") + b"\x01\x02"), out)
    # a truncated last frame (its parent died mid-write) ends the loop quietly
    assert frames(out.getvalue()) == [(READY, b""), (ord("A"), b"cba"), (ord("B"), b"")]


def test_an_error_goes_back_with_its_traceback_and_ends_the_loop():
    def handle(code: int, body: bytearray) -> tuple[int, bytes]:
        raise ValueError(f"no request {chr(code)}")

    out = io.BytesIO()
    serve(handle, io.BytesIO(request("Q") + request("R")), out)
    (ready, _), (code, text) = frames(out.getvalue())
    assert ready == READY and code == ERROR
    assert b"Traceback" in text and b"ValueError: no request Q" in text


def test_a_parent_gone_ends_the_loop_quietly():
    class Closed(io.BytesIO):
        def write(self, data) -> int:
            raise BrokenPipeError

    serve(lambda code, body: (code, b""), io.BytesIO(request("A")), Closed())  # no exception


ECHO = (
    "from navlog.replay.workers.child import serve; "
    "serve(lambda code, body: None if code == ord('N') else (code, bytes(body) * 2))"
)


def test_a_parent_asks_a_real_child_and_takes_the_replies_in_order():
    child = ChildProcess("echo process", ECHO)
    try:
        child.send(ord("N"), b"ignored")
        for k in range(5):
            child.ask(ord("A"), bytes([k]) * 300_000)  # 600 kB replies, not yet taken
        assert child.owed == 5
        assert [bytes(child.reply()) for _ in range(5)] == [bytes([k]) * 600_000 for k in range(5)]
        assert child.started() and not child.reply_ready()
        with pytest.raises(RuntimeError, match="no reply is owed"):
            child.reply()
    finally:
        child.close()
    assert child.process is None
    with pytest.raises(NavlogError, match=r"echo process \(pid \?\) ended unexpectedly"):
        child.send(ord("A"), b"")


def test_the_child_has_a_process_group_of_its_own_so_a_terminal_ctrl_c_reaches_the_replay_only():
    child = ChildProcess("echo process", ECHO)
    try:
        assert child.pid is not None
        assert os.getpgid(child.pid) == child.pid != os.getpgid(0)
        child.ask(ord("A"), b"x")
        assert bytes(child.reply()) == b"xx"  # it answers as before
    finally:
        child.close()


def test_a_request_after_the_child_failed_raises_its_error_not_a_broken_pipe():
    child = ChildProcess(
        "echo process", "from navlog.replay.workers.child import serve; serve(lambda code, body: 1 // 0)"
    )
    try:
        child.send(ord("A"), b"")  # the child fails on it, sends its error and ends
        assert child.process is not None
        child.process.wait(timeout=60)
        with pytest.raises(NavlogError, match=r"echo process \(pid \d+\) failed:\n(?s:.*)ZeroDivisionError"):
            child.send(ord("A"), b"x")  # its input is closed: the write breaks, its error is read
    finally:
        child.close()
    assert child.process is None


def test_a_python_run_to_its_end_gives_its_output_and_code_and_is_killed_past_its_time():
    import time

    from navlog.replay.workers.child import run_python

    out, code = run_python(
        "import sys; sys.stdout.buffer.write(sys.argv[1].encode()); sys.exit(3)", args=["hi"], timeout=30
    )
    assert (out, code) == (b"hi", 3)
    start = time.monotonic()
    out, code = run_python("import sys, time; sys.stdout.buffer.write(b'x'); time.sleep(60)", timeout=1.0)
    assert out == b"" and code < 0 and time.monotonic() - start < 10


def test_a_python_run_is_held_to_its_cpu_time_and_memory():
    import signal
    import time

    from navlog.replay.workers.child import run_python

    start = time.monotonic()
    out, code = run_python("while True: pass", timeout=30, cpu_seconds=1)
    assert code == -signal.SIGXCPU and time.monotonic() - start < 10
    grab = "import sys\ntry:\n    b = bytearray(1 << 30)\nexcept MemoryError:\n    sys.stdout.write('refused')"
    assert run_python(grab, timeout=30, memory=512 << 20) == (b"refused", 0)
    assert run_python(grab.replace("1 << 30", "1 << 20"), timeout=30, memory=512 << 20) == (b"", 0)


def test_a_limit_not_asked_for_is_left_as_inherited_even_below_infinity():
    from navlog.replay.workers.child import run_python

    # a parent whose address space has a finite hard limit asks its child for a CPU limit only
    parent = (
        "import resource, sys\n"
        "resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))\n"
        "from navlog.replay.workers.child import run_python\n"
        "out, code = run_python('import resource; print(resource.getrlimit(resource.RLIMIT_AS)[0])', "
        "timeout=30, cpu_seconds=5)\n"
        "sys.stdout.buffer.write(out + str(code).encode())"
    )
    out, code = run_python(parent, timeout=60)
    assert (out, code) == (f"{8 << 30}\n0".encode(), 0)
