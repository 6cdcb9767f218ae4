"""Outputs: never written through a symlink, never replacing a device, FIFO or socket; a read-only
folder, a full disk or a file-size limit is one line naming the output, exit 2, and no file left."""

from __future__ import annotations

import contextlib
import errno
import os
import resource
import signal
import socket
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navlog.analysis.metrics.report import write_json
from navlog.cli import main
from navlog.errors import NavlogError
from navlog.replay.io import atomic
from navlog.replay.io.map_server import save_map
from navlog.replay.occupancy_map import OccupancyMap

NAVLOG = [sys.executable, "-m", "navlog"]


def _room(tmp_path: Path) -> Path:
    data = np.zeros((60, 60), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    return save_map(OccupancyMap(data, 0.05, (-1.5, -1.5, 0.0)), tmp_path / "room.yaml")[0]


def _plan(tmp_path: Path, png: Path) -> list[str]:
    return ["plan", "--map", str(_room(tmp_path)), "--start=-0.5,0,0", "--goal", "0.5,0,0", "--png", str(png)]


def _outputs(log: Path, out: Path) -> dict[str, list[str]]:
    return {  # (metrics -o is written by the same helper, write_file: tested below through metrics' write_json)
        "diff --json": ["diff", str(log), str(log), "--json", str(out)],
        "diff --markdown": ["diff", str(log), str(log), "--markdown", str(out)],
        "export tum": ["export", str(log), "--to", "tum", "--topic", "/odom", "-o", str(out)],
    }


@pytest.fixture(params=["fifo", "socket"])
def special(request, tmp_path):
    path = tmp_path / f"out.{request.param}"
    if request.param == "fifo":
        os.mkfifo(path)
        yield path
        return
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        yield path


def _unchanged(path: Path, mode: int) -> None:
    assert stat.S_IFMT(os.lstat(path).st_mode) == mode
    assert [p.name for p in path.parent.iterdir() if p.name.startswith(f".{path.name}")] == []


def test_a_special_file_is_refused_as_an_output(special, tmp_path, teleop_log, capsys):
    mode = stat.S_IFMT(os.lstat(special).st_mode)
    outputs = {**_outputs(teleop_log, special), "metrics -o": ["metrics", str(teleop_log), "-o", str(special)]}
    for name, argv in [*outputs.items(), ("plan --png", _plan(tmp_path, special))]:
        assert main([*argv, "--force"]) == 2, name
        err = capsys.readouterr().err
        assert err.startswith(f"navlog: error: {special}: is a "), (name, err)
        assert "not a file; navlog does not write to it" in err and err.count("\n") == 1
        _unchanged(special, mode)
    with pytest.raises(NavlogError, match="is a "):
        atomic.write_file(special, b"x")
    _unchanged(special, mode)


def test_a_symlink_at_an_output_is_replaced_not_written_through(tmp_path, capsys):
    target = tmp_path / "precious.txt"
    target.write_text("keep\n")
    link = tmp_path / "plan.png"
    link.symlink_to(target)
    assert main([*_plan(tmp_path, link), "--force"]) == 0
    assert target.read_text() == "keep\n"
    assert not link.is_symlink() and link.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _lowest_write_fails(monkeypatch, code: int) -> None:
    """Every file that ``navlog.replay.io.atomic`` opens fails its first write with ``code``."""

    class Failing:
        def __init__(self, f):
            self.f = f

        def write(self, data):
            raise OSError(code, os.strerror(code))

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

    real = atomic.open_new
    monkeypatch.setattr(atomic, "open_new", lambda path: Failing(real(path)))


@pytest.mark.parametrize(
    ("code", "words"), [(errno.ENOSPC, "No space left on device"), (errno.EFBIG, "File too large")]
)
def test_a_failed_write_is_one_line_and_leaves_nothing(code, words, tmp_path, teleop_log, monkeypatch, capsys):
    plan = _plan(tmp_path, tmp_path / "out.x")
    _lowest_write_fails(monkeypatch, code)
    for name, argv in [*_outputs(teleop_log, tmp_path / "out.x").items(), ("plan", plan)]:
        assert main(argv) == 2, name
        err = capsys.readouterr().err
        assert (
            err
            == f"navlog: error: {tmp_path / 'out.x'}: cannot write: {words} (a full disk or a file-size limit?); the partial file was removed\n"
        ), name
        assert sorted(p.name for p in tmp_path.iterdir()) == ["room.pgm", "room.yaml"], name


def test_a_file_size_limit_in_a_real_process(tmp_path, teleop_log):
    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write fails with EFBIG instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (48, 48))  # below each output's size

    plan = _plan(tmp_path, tmp_path / "out" / "plan.png")
    out = tmp_path / "out"
    out.mkdir()
    for name, argv in [*_outputs(teleop_log, out / "report").items(), ("plan", plan)]:
        proc = subprocess.run([*NAVLOG, *argv], capture_output=True, text=True, timeout=300, preexec_fn=limit)
        assert proc.returncode == 2, (name, proc.stderr)
        assert "cannot write: File too large" in proc.stderr and "Traceback" not in proc.stderr, name
        assert len(proc.stderr.strip().splitlines()) == 1, (name, proc.stderr)
        assert list(out.iterdir()) == [], name


@contextlib.contextmanager
def _tmpfs(path: Path, options: str):
    path.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here")
    try:
        yield path
    finally:
        subprocess.run(["umount", str(path)], check=True)


def test_a_read_only_folder_and_a_full_disk(tmp_path, teleop_log, capsys):
    if os.geteuid() != 0:  # a user's read-only folder: chmod is enough
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        folders = contextlib.nullcontext(ro)
    else:  # root writes through chmod: a read-only tmpfs
        folders = _tmpfs(tmp_path / "ro", "ro,size=64k")
    with folders as ro:
        for name, argv in [*_outputs(teleop_log, ro / "out").items(), ("plan", _plan(tmp_path, ro / "out"))]:
            assert main(argv) == 2, name
            err = capsys.readouterr().err
            assert err.startswith(f"navlog: error: {ro / 'out'}: cannot write: "), (name, err)
            assert "(a read-only folder?); nothing was written" in err and err.count("\n") == 1, name
    with _tmpfs(tmp_path / "full", "size=16k") as full:
        with contextlib.suppress(OSError), open(full / "filler", "wb") as f:
            f.write(b"\0" * 64 * 1024)  # until the disk is full
        assert main(["diff", str(teleop_log), str(teleop_log), "--json", str(full / "diff.json")]) == 2
        err = capsys.readouterr().err
        assert "diff.json: cannot write: No space left on device" in err
        with pytest.raises(NavlogError, match="metrics.json: cannot write: No space left on device"):
            write_json({"ate": {"rmse": 1.0, "text": "x" * 8192}}, full / "metrics.json")
        assert sorted(p.name for p in full.iterdir()) == ["filler"]


@pytest.mark.parametrize(
    ("address", "name"),
    [
        ("/logs/run.mcap", "run"),
        ("/logs/..mcap", "_-"),
        ("/logs/.mcap", "_mcap-"),
        ("s3://bucket/x/..", "_.-"),
        ("/logs/a b\x01.mcap", "a_b_-"),
        ("/logs/" + "y" * 300 + ".mcap", "y" * 100 + "-"),
    ],
)
def test_fleet_output_names_stay_inside_their_folder(address, name):
    from navlog.analysis.fleet.inputs import _stem

    stem = _stem(address)
    assert stem == name if name == "run" else (stem.startswith(name) and len(stem) == len(name) + 8)
    assert "/" not in stem and not stem.startswith(".") and len(stem) <= 109


def test_record_and_world_map_refuse_special_outputs_and_a_file_as_folder(tmp_path, capsys):
    fifo = tmp_path / "run.mcap"
    os.mkfifo(fifo)
    assert main(["record", "--scenario", "teleop", "-o", str(fifo), "--force"]) == 2
    assert f"{fifo}: is a FIFO (named pipe), not a file" in capsys.readouterr().err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    (tmp_path / "file").write_text("")
    assert main(["world-map", "indoor_room", "-o", str(tmp_path / "file" / "map.yaml")]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith(f"navlog: error: {tmp_path / 'file' / 'map.yaml'}: cannot write map: ") and err.count("\n") == 1
    )


def _limited() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["export", "LOG", "--to", "rosbag2", "-o", "OUT"], "OUT: cannot write: disk I/O error"),
        (["export", "LOG", "--to", "rosbag2", "--storage", "mcap", "-o", "OUT"], "OUT: cannot write: File too large"),
        (["view", "LOG", "--save", "OUT"], "OUT: cannot write: File-writer thread shut down prematurely"),
        (
            ["replay", "LOG", "--pipeline", "mapping", "-o", "OUT", "--no-metrics"],
            "OUT/replay.mcap: cannot write: File too large",
        ),
    ],
)
def test_library_writers_under_a_file_size_limit(argv, words, tmp_path, teleop_log):
    out = tmp_path / "out"
    out.mkdir()
    target = out / ("result.rrd" if argv[0] == "view" else "result")
    cmd = [*NAVLOG, "-q", *(str(teleop_log) if a == "LOG" else str(target) if a == "OUT" else a for a in argv)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, preexec_fn=_limited)
    assert proc.returncode == 2, proc.stderr
    errors = [x for x in proc.stderr.splitlines() if x.startswith("navlog: error:")]
    assert len(errors) == 1 and words.replace("OUT", str(target)) in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr
    assert list(out.iterdir()) == []
