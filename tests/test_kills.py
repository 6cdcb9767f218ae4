"""Outputs survive ``kill -9`` at any instant and a full disk.

``navlog record``, ``replay``, ``export --to rosbag2`` and ``view --save`` run as subprocesses and are
killed with SIGKILL at seeded random instants spread over the run time measured first. After every kill:
a file under the final name is complete (the MCAP opens untruncated with every message, the map loads
and matches its manifest, the bag and the .rrd read back whole), an output that ``--force`` was replacing
is still there byte for byte, and ``navlog recover`` salvages every complete chunk of the killed
recording's ``.part`` file. A file-size limit during ``record`` gives one clear error and leaves nothing.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import random
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # every test runs navlog in subprocesses, most of them many times

NAVLOG = Path(sys.executable).with_name("navlog")
QUICK_KILLS = 3  # per command
FULL_KILLS = 20  # per command
SEED = 20240614


def _run(argv: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(NAVLOG), "-q", *argv], capture_output=True, text=True, timeout=300, **kw)


def _digest(path: Path) -> str:
    """sha256 of a file, or of every file of a folder with its name."""
    h = hashlib.sha256()
    for p in sorted(path.rglob("*")) if path.is_dir() else [path]:
        if p.is_file():
            h.update(p.relative_to(path).as_posix().encode() if path.is_dir() else b"")
            h.update(p.read_bytes())
    return h.hexdigest()


# --- what a complete output is, per command ------------------------------------------------------------------


def _mcap_complete(path: Path, counts: dict[str, int]) -> None:
    from navlog.replay.io import open_log

    with open_log(path) as reader:
        assert not reader.report.truncated
        assert {t: i.count for t, i in reader.topics.items()} == counts
        assert sum(1 for _ in reader.messages(sorted(counts), decode=False)) == sum(counts.values())


def _replay_complete(path: Path) -> None:
    from navlog.replay.io.map_server import load_map

    manifest = json.loads((path / "manifest.json").read_text())
    files = {o["file"]: o["sha256"] for o in manifest["outputs"].values()}
    assert {p.name for p in path.iterdir()} == {*files, "manifest.json"}
    assert {f: _digest(path / f) for f in files} == files
    assert load_map(path / "map.yaml").data.shape[0] > 50


def _bag_complete(path: Path, total: int) -> None:
    from rosbags.rosbag2 import Reader

    with Reader(path) as r:
        assert r.message_count == total
        assert sum(1 for _ in r.messages()) == total


def _rrd_chunks(path: Path) -> dict[str, int]:
    from rerun.chunk import RrdReader

    out: dict[str, int] = {}
    for ch in RrdReader(path).stream().collect().stream():
        out[ch.entity_path] = out.get(ch.entity_path, 0) + ch.num_rows
    return out


@dataclass
class Command:
    """One command under test: its arguments for an output, and the check that an output is whole."""

    name: str
    argv: Callable[[Path], list[str]]
    output: str
    complete: Callable[[Path], None] = field(repr=False)
    run_s: float = 0.0
    reference: str = ""  # digest of the output of an uninterrupted run


@dataclass
class Tally:
    kills: int = 0
    final_absent: int = 0  # killed before the output appeared
    final_complete: int = 0  # a complete new output under the final name
    previous_intact: int = 0  # --force was replacing an output: the old one is still there, byte for byte
    recovered: int = 0  # killed recordings whose .part `navlog recover` salvaged (every complete chunk)
    recover_refused: int = 0  # killed before the first chunk was whole: `navlog recover` says so, writes nothing
    salvaged_messages: int = 0


@pytest.fixture(scope="module")
def workbench(tmp_path_factory) -> tuple[Path, dict[str, Command]]:
    """A teleop recording and, for each command, its measured run time and a reference output."""
    base = tmp_path_factory.mktemp("kills")
    log = base / "teleop.mcap"
    record = ["record", "--world", "indoor_room", "--scenario", "teleop", "--seed", "3"]
    t0 = time.perf_counter()
    assert _run([*record, "-o", str(log)]).returncode == 0
    record_s = time.perf_counter() - t0
    from navlog.replay.io import open_log

    with open_log(log) as reader:
        counts = {t: i.count for t, i in reader.topics.items()}
    commands = {
        "record": Command("record", lambda o: [*record, "-o", str(o)], "run.mcap", lambda p: _mcap_complete(p, counts)),
        "replay": Command(
            "replay",
            lambda o: ["replay", str(log), "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", str(o)],
            "rep",
            _replay_complete,
        ),
        "export": Command(
            "export",
            lambda o: ["export", str(log), "--to", "rosbag2", "-o", str(o)],
            "bag",
            lambda p: _bag_complete(p, sum(counts.values())),
        ),
        "view": Command("view", lambda o: ["view", str(log), "--save", str(o)], "v.rrd", lambda p: None),
    }
    ref_dir = base / "reference"
    ref_dir.mkdir()
    for cmd in commands.values():
        out = ref_dir / cmd.output
        times = [record_s] if cmd.name == "record" else []
        for target in (out, ref_dir / f"again-{cmd.output}"):
            t0 = time.perf_counter()
            done = _run(cmd.argv(target))
            times.append(time.perf_counter() - t0)
            assert done.returncode == 0, done.stderr
        # a run's time at its quickest (a first run warms caches, a busy moment slows one): the kill instants, drawn
        # within it, fall inside most runs
        cmd.run_s = min(times)
        cmd.complete(out)
        cmd.reference = _digest(out)
    view_ref = _rrd_chunks(ref_dir / "v.rrd")
    assert len(view_ref) > 10

    def view_complete(p: Path) -> None:
        assert _rrd_chunks(p) == view_ref

    commands["view"].complete = view_complete
    assert _digest(log) == commands["record"].reference  # the recording is deterministic: a .part is its prefix
    return base, commands


def _complete_chunk_messages(reference: Path, size: int) -> int:
    """Messages in the chunks of ``reference`` that end within its first ``size`` bytes."""
    from mcap.exceptions import EndOfFile
    from mcap.reader import make_reader
    from mcap.records import Message
    from mcap.stream_reader import StreamReader

    data = reference.read_bytes()
    with open(reference, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    n = 0
    for ci in summary.chunk_indexes:
        if ci.chunk_start_offset + ci.chunk_length <= size:
            chunk = io.BytesIO(data[ci.chunk_start_offset : ci.chunk_start_offset + ci.chunk_length])
            records = StreamReader(chunk, skip_magic=True).records
            try:
                for r in records:
                    n += isinstance(r, Message)
            except EndOfFile:  # the chunk alone, without the records after it
                pass
    return n


def _kill_at(argv: list[str], delay_s: float) -> int | None:
    """Start a command, SIGKILL it after ``delay_s``; its exit code when it finished first, else None."""
    proc = subprocess.Popen([str(NAVLOG), "-q", *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        code = proc.wait(timeout=delay_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        return None
    assert code == 0, proc.stderr.read().decode() if proc.stderr else ""
    return code


def _sweep(base: Path, cmd: Command, kills: int, seed: int) -> Tally:
    rng = random.Random(f"{seed}-{cmd.name}")
    work = base / f"{cmd.name}-{kills}-{seed}"
    work.mkdir()
    reference = base / "reference" / cmd.output
    tally = Tally()
    for i in range(kills):
        delay = rng.uniform(0.05, 0.9 * cmd.run_s)
        replacing = i % 2 == 1  # every other kill lands on a run that replaces a finished output with --force
        out = work / f"{i}-{cmd.output}"
        if replacing:
            _copy(reference, out)
        finished = _kill_at([*cmd.argv(out), *(["--force"] if replacing else [])], delay)
        tally.kills += finished is None
        if not out.exists():
            assert not replacing, f"{cmd.name}: killed at {delay:.2f} s, the output it was replacing is gone"
            tally.final_absent += 1
        elif replacing and _digest(out) == cmd.reference and finished is None:
            tally.previous_intact += 1  # (a new output has the same bytes; both are whole)
            cmd.complete(out)
        else:
            cmd.complete(out)
            tally.final_complete += 1
        part = out.with_name(out.name + ".part")
        if cmd.name == "record" and part.exists():
            _check_recover(part, reference, tally)
    return tally


def _copy(src: Path, dst: Path) -> None:
    import shutil

    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copyfile(src, dst)


def _check_recover(part: Path, reference: Path, tally: Tally) -> None:
    size = part.stat().st_size
    assert part.read_bytes() == reference.read_bytes()[:size]  # the killed file is a prefix of a whole one
    fixed = part.with_name(part.name + ".recovered.mcap")
    done = _run(["recover", str(part), "-o", str(fixed)])
    if size < 8:  # killed before the magic bytes were written
        said = "the file is empty (0 bytes)" if size == 0 else "not an MCAP file"
        assert done.returncode == 2 and said in done.stderr and "Traceback" not in done.stderr
        return
    expected = _complete_chunk_messages(reference, size)
    if expected == 0:  # killed before its first chunk was whole: a clear error, and nothing written
        assert done.returncode == 2 and "nothing to recover" in done.stderr and "Traceback" not in done.stderr
        assert not fixed.exists() and not fixed.with_name(fixed.name + ".part").exists()
        tally.recover_refused += 1
        return
    assert done.returncode == 0, done.stderr
    from navlog.replay.io import open_log

    with open_log(fixed) as reader:
        assert not reader.report.truncated
        assert sum(i.count for i in reader.topics.values()) == expected
    assert f"kept {expected} messages" in done.stdout
    tally.recovered += 1
    tally.salvaged_messages += expected


COMMANDS = ("record", "replay", "export", "view")


@pytest.mark.parametrize("name", COMMANDS)
def test_kill_9_at_random_instants_quick(workbench, name):
    base, commands = workbench
    tally = _sweep(base, commands[name], QUICK_KILLS, SEED)
    assert tally.final_absent + tally.final_complete + tally.previous_intact == QUICK_KILLS
    print(f"{name}: {tally}")


@pytest.mark.parametrize("name", COMMANDS)
def test_kill_9_at_random_instants_full(workbench, name):
    base, commands = workbench
    tally = _sweep(base, commands[name], FULL_KILLS, SEED + 1)
    assert tally.final_absent + tally.final_complete + tally.previous_intact == FULL_KILLS
    assert tally.kills >= FULL_KILLS // 2  # most instants fall inside the run, not after it
    print(f"{name}: {tally}")


def _leftovers(folder: Path, out: Path) -> list[str]:
    """What lies beside ``out`` besides ``out`` itself and what the test put there: a killed run's leftovers."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith((f".{out.name}.", f"{out.name}.part")))


@pytest.mark.parametrize("name", COMMANDS)
def test_the_next_run_clears_what_a_killed_run_left(workbench, tmp_path, name):
    """A run killed mid-write leaves its temporary; the next run of the same command for the same output
    removes it (record reuses its ``NAME.part``, the others remove ``.NAME.PID.part`` of dead processes)."""
    base, commands = workbench
    cmd = commands[name]
    out = tmp_path / cmd.output
    left: list[str] = []
    for _ in range(3):  # kill as soon as the temporary appears (a run may finish before it is seen)
        proc = subprocess.Popen([str(NAVLOG), "-q", *cmd.argv(out), "--force"], stdout=subprocess.DEVNULL)
        while proc.poll() is None and not _leftovers(tmp_path, out):
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        left = _leftovers(tmp_path, out)
        if left:
            break
    assert left, f"{name}: no kill left a temporary"
    done = _run([*cmd.argv(out), "--force"])
    assert done.returncode == 0, done.stderr
    cmd.complete(out)
    assert _leftovers(tmp_path, out) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


# --- a full disk ----------------------------------------------------------------------------------------------


def _file_size_limit(limit: int) -> Callable[[], None]:
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.parametrize("limit", [0, 3_000_000, 20_000_000])
def test_record_on_a_full_disk_fails_clearly_and_leaves_nothing(tmp_path, limit):
    out = tmp_path / "run.mcap"
    argv = ["record", "--world", "indoor_room", "--scenario", "teleop", "--seed", "3", "-o", str(out)]
    done = _run(argv, preexec_fn=_file_size_limit(limit), cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert f"navlog: error: {out}: cannot write: File too large" in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_record_over_an_existing_output_on_a_full_disk_keeps_it(tmp_path, workbench):
    base, commands = workbench
    out = tmp_path / "run.mcap"
    _copy(base / "reference" / "run.mcap", out)
    argv = ["record", "--world", "indoor_room", "--scenario", "teleop", "--seed", "3", "-o", str(out), "--force"]
    done = _run(argv, preexec_fn=_file_size_limit(5_000_000))
    assert done.returncode == 2 and "cannot write" in done.stderr and "Traceback" not in done.stderr
    assert _digest(out) == commands["record"].reference
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]
    assert os.path.getsize(out) > 20_000_000


# --- the sensor worker of a recording -------------------------------------------------------------------------


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except FileNotFoundError:
        return []


def _running(pid: int) -> bool:
    """True while ``pid`` runs (a zombie has ended: only its exit status waits to be collected)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads child processes from /proc")
@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="on one CPU a recording starts no worker")
@pytest.mark.parametrize("how", ["kill -9", "Ctrl-C"])
def test_a_stopped_recording_leaves_no_sensor_worker(tmp_path, how):
    """The laser and LiDAR worker process ends with its recording: killed (its request pipe closes) or
    interrupted (the recording closes its file, then ends the worker and waits for it)."""
    out = tmp_path / "run.mcap"
    argv = ["record", "--world", "indoor_room", "--scenario", "mapping", "--seed", "3", "-o", str(out)]
    proc = subprocess.Popen([str(NAVLOG), "-q", *argv], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not (workers := _children(proc.pid)) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert workers, "no sensor worker process was started"
    (worker,) = workers
    cmdline = Path(f"/proc/{worker}/cmdline")
    while "range_sensors" not in cmdline.read_text() and time.monotonic() < deadline:
        time.sleep(0.01)  # forked, not yet the new program
    assert "navlog.recorder.range_sensors" in cmdline.read_text()
    part = out.with_name(out.name + ".part")
    while proc.poll() is None and time.monotonic() < deadline and (not part.exists() or part.stat().st_size < 2e6):
        time.sleep(0.01)  # well into the run: its first chunks are written
    proc.send_signal(signal.SIGKILL if how == "kill -9" else signal.SIGINT)
    code = proc.wait(timeout=60)
    deadline = time.monotonic() + 10
    while _running(worker) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not _running(worker)
    if how == "Ctrl-C":
        assert code == 130, proc.stderr.read().decode() if proc.stderr else ""
        _mcap_complete_any(out)
    else:
        assert code == -signal.SIGKILL and not out.exists()


def _mcap_complete_any(path: Path) -> None:
    from navlog.replay.io import open_log

    with open_log(path) as reader:
        assert not reader.report.truncated
        assert reader.topics["/scan"].count > 5 and reader.topics["/livox/lidar"].count > 5


def test_sigterm_cleans_up_as_ctrl_c_does(tmp_path, teleop_log):
    """SIGTERM (a `timeout`, a CI job cancelled) mid-replay exits 143 saying so, and leaves neither the replay's
    temporary folder nor its lock; mid-recording it closes the file cleanly, as the first Ctrl-C does. Before,
    it killed the process where it stood, leaving both behind."""
    out = tmp_path / "out"
    argv = [str(NAVLOG), "replay", str(teleop_log), "--pipeline", "mapping", "-o", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    partial = tmp_path / ".out.partial"
    deadline = time.monotonic() + 60
    while not partial.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    assert partial.exists(), "the replay ended before it could be stopped"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "navlog: terminated (SIGTERM)" in err and "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    rec = tmp_path / "run.mcap"
    argv = [str(NAVLOG), "record", "--world", "indoor_room", "--scenario", "mapping", "--seed", "3", "-o", str(rec)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    part = rec.with_name(rec.name + ".part")
    while proc.poll() is None and time.monotonic() < deadline + 60 and (not part.exists() or part.stat().st_size < 2e6):
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    stdout, err = proc.communicate(timeout=120)
    assert proc.returncode == 143 and "interrupted, file closed cleanly" in stdout, err
    _mcap_complete_any(rec)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads child processes from /proc")
def test_a_fleets_workers_end_with_their_parent_killed_with_kill_9(tmp_path, teleop_log):
    """A worker blocked reading its pipe never saw its parent go: after kill -9 of a fleet (or a campaign) its
    workers lived on, a few hundred MB each. They now end with it."""
    logs = [tmp_path / f"run{i}.mcap" for i in range(4)]
    for log in logs:
        log.write_bytes(teleop_log.read_bytes())
    argv = [str(NAVLOG), "-q", "replay", *map(str, logs), "--pipeline", "mapping", "--workers", "2"]
    proc = subprocess.Popen([*argv, "-o", str(tmp_path / "out")], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60

    def workers() -> list[int]:
        return [c for c in _children(proc.pid) if "spawn_main" in Path(f"/proc/{c}/cmdline").read_text()]

    while len(found := workers()) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert len(found) == 2, "the fleet started no two workers"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    deadline = time.monotonic() + 10
    while any(_running(w) for w in found) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_running(w) for w in found)
