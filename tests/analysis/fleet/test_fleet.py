"""Fleet replay end to end: every log into its own folder with the bytes a single replay writes, failed
logs reported alone, the same outputs and summary in this process and in a pool, resuming, the CLI,
fsspec URLs, and Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from navlog.analysis.fleet import replay_fleet
from navlog.cli import main
from navlog.errors import ConfigError
from tests.analysis.fleet.conftest import OVERRIDES, copy_log, folder_bytes

TELEOP_S = 17.0  # the teleop scenario's length


def _without_input_names(files: dict[str, bytes]) -> dict[str, object]:
    """A replay folder's bytes, the manifest parsed with its input file names left out (they name the log)."""
    out: dict[str, object] = dict(files)
    manifest = json.loads(files["manifest.json"])
    for entry in manifest["inputs"]:
        entry.pop("file")
    out["manifest.json"] = manifest
    return out


@pytest.fixture(scope="module")
def pool_run(fleet_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("fleet-pool") / "out"
    return replay_fleet([fleet_dir], "mapping", out, overrides=OVERRIDES, workers=2, progress=False)


def test_every_log_gets_its_folder_and_a_row_and_bad_logs_fail_alone(pool_run, fleet_dir, reference):
    res = pool_run
    out = Path(res.out)
    assert res.executor == "2 worker processes"
    assert [(r.name, r.status) for r in res.results] == [
        ("a", "ok"),
        ("b", "ok"),
        ("empty", "failed"),
        ("trunc", "failed"),
    ]
    empty, trunc = res.results[2], res.results[3]
    assert empty.reason.startswith(f"{fleet_dir / 'empty.mcap'}: the file is empty (0 bytes)")
    assert "truncated" in trunc.reason and "--recover" in trunc.reason
    # each log's folder holds what `navlog replay LOG -o OUT/NAME` writes, byte for byte
    ref = folder_bytes(reference)
    for name in ("a", "b"):
        assert _without_input_names(folder_bytes(out / name)) == _without_input_names(ref)
    assert json.loads((out / "a" / "manifest.json").read_text())["inputs"][0]["file"] == "a.mcap"
    assert sorted(p.name for p in (out / ".fleet").iterdir()) == ["a.json", "b.json"]  # nothing half-built
    assert sorted(p.name for p in out.iterdir()) == [
        ".fleet",
        "a",
        "b",
        "fleet-summary.csv",
        "fleet-summary.json",
        "fleet-summary.md",
    ]
    manifest = json.loads(ref["manifest.json"])
    totals = res.summary["totals"]
    assert totals == {
        "logs": 4,
        "ok": 2,
        "failed": 2,
        "cached": 0,
        "duration_s": 2 * TELEOP_S,
        "messages": 2 * manifest["log"]["messages_read"],
        "published": 2 * sum(manifest["published"].values()),
        "skipped": 2 * sum(manifest["skipped"].values()),
    }
    a = res.summary["logs"][0]
    assert a["duration_s"] == TELEOP_S and a["outputs"]["map.pgm"] == manifest["outputs"]["map_pgm"]["sha256"]
    # the map comes from ground-truth poses: the trajectory error is zero to rounding
    assert a["metrics"]["trajectory.ate.translation_m.rmse"] < 1e-6
    assert a["metrics"]["trajectory.ate.pairs"] > 30


def test_this_process_and_the_pool_write_the_same_bytes(pool_run, fleet_dir, tmp_path):
    here = replay_fleet([fleet_dir], "mapping", tmp_path / "out", overrides=OVERRIDES, workers=1, progress=False)
    assert here.executor == "this process"
    assert folder_bytes(tmp_path / "out") == folder_bytes(Path(pool_run.out))


def test_a_rerun_reuses_up_to_date_outputs_and_redoes_changed_or_forced_ones(fleet_dir, reference, tmp_path):
    logs = [fleet_dir / "a.mcap", fleet_dir / "b.mcap"]
    out = tmp_path / "out"
    first = replay_fleet(logs, "mapping", out, overrides=OVERRIDES, workers=1, progress=False)
    stamp = (out / "a" / "map.pgm").stat().st_mtime_ns
    again = replay_fleet(logs, "mapping", out, overrides=OVERRIDES, workers=1, progress=False)
    assert [r.cached for r in again.results] == [True, True]
    assert (out / "a" / "map.pgm").stat().st_mtime_ns == stamp
    rows = [{k: v for k, v in row.items() if k != "cached"} for row in again.summary["logs"]]
    assert rows == [{k: v for k, v in row.items() if k != "cached"} for row in first.summary["logs"]]
    # an output file that went missing, changed parameters, or --force: replayed again
    (out / "b" / "map.pgm").unlink()
    changed = replay_fleet(
        logs, "mapping", out, overrides=[*OVERRIDES, "occupancy.grid.resolution=0.1"], workers=1, progress=False
    )
    assert [r.cached for r in changed.results] == [False, False]
    assert json.loads((out / "a" / "manifest.json").read_text())["parameters"]["occupancy"]["grid"]["resolution"] == 0.1
    forced = replay_fleet(logs[:1], "mapping", out, overrides=OVERRIDES, force=True, workers=1, progress=False)
    assert [r.cached for r in forced.results] == [False]
    assert folder_bytes(out / "a")["map.pgm"] == folder_bytes(reference)["map.pgm"]


def test_a_folder_that_is_not_a_replay_is_not_overwritten_without_force(fleet_dir, tmp_path):
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (out / "a" / "notes.txt").write_text("mine\n")
    res = replay_fleet([fleet_dir / "a.mcap"], "mapping", out, overrides=OVERRIDES, workers=1, progress=False)
    assert res.results[0].status == "failed"
    assert "holds no replay (no manifest.json)" in res.results[0].reason and "--force" in res.results[0].reason
    assert (out / "a" / "notes.txt").read_text() == "mine\n"


def test_the_cli_replays_a_fleet_and_exits_1_when_a_log_failed(fleet_dir, tmp_path, capsys):
    base = ["replay", "--pipeline", "mapping", "--set", "lidar_mapper=off", "--workers", "1"]
    listing = tmp_path / "logs.txt"
    listing.write_text(f"{fleet_dir / 'a.mcap'}\n# the copy\n{fleet_dir / 'b.mcap'}\n")
    assert main(["-q", *base, "--list", str(listing), "-o", str(tmp_path / "ok")]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"replayed 2 logs through 'mapping' into {tmp_path / 'ok'}/ on this process in ")
    assert "2 ok (0 up to date, reused), 0 failed" in out
    assert main(["-q", *base, str(fleet_dir / "a.mcap"), str(fleet_dir / "empty.mcap"), "-o", str(tmp_path / "x")]) == 1
    summary = json.loads((tmp_path / "x" / "fleet-summary.json").read_text())
    assert [row["status"] for row in summary["logs"]] == ["ok", "failed"]


def test_the_cli_says_how_to_install_ray_when_it_is_missing(fleet_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    code = main(["replay", str(fleet_dir / "a.mcap"), "--pipeline", "mapping", "-o", str(tmp_path / "o"), "--ray"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert "navlog: error: --ray needs Ray, which is not installed: pip install navlog[fleet]" in err


def test_logs_and_outputs_through_fsspec_urls(fleet_dir, reference, tmp_path):
    import fsspec

    fs = fsspec.filesystem("memory")
    fs.pipe_file("/fleet-urls/logs/a.mcap", (fleet_dir / "a.mcap").read_bytes())
    try:
        res = replay_fleet(
            ["memory://fleet-urls/logs/"], "mapping", "memory://fleet-urls/out", overrides=OVERRIDES, progress=False
        )
        assert [(r.log, r.status) for r in res.results] == [("memory:///fleet-urls/logs/a.mcap", "ok")]
        ref = folder_bytes(reference)
        stored = {p.rsplit("/", 1)[1]: fs.cat_file(p) for p in fs.find("/fleet-urls/out/a")}
        assert _without_input_names(stored) == _without_input_names(ref)
        assert json.loads(fs.cat_file("/fleet-urls/out/fleet-summary.json"))["totals"]["ok"] == 1
        again = replay_fleet(
            ["memory://fleet-urls/logs/a.mcap"],
            "mapping",
            "memory://fleet-urls/out",
            overrides=OVERRIDES,
            progress=False,
        )
        assert again.results[0].cached
        # file:// URLs are local paths
        local = replay_fleet(
            [f"file://{fleet_dir}/a.mcap"], "mapping", f"file://{tmp_path}/out", overrides=OVERRIDES, progress=False
        )
        assert local.results[0].ok and (tmp_path / "out" / "a" / "manifest.json").is_file()
        with pytest.raises(
            ConfigError, match=r"memory:///fleet-urls/logs/a\.mcap: this filesystem lives in one process"
        ):
            replay_fleet(
                ["memory://fleet-urls/logs/", fleet_dir / "b.mcap"],
                "mapping",
                tmp_path / "o2",
                workers=2,
                progress=False,
            )
    finally:
        fs.rm("/fleet-urls", recursive=True)


@pytest.mark.parametrize("how", ["Ctrl-C", "SIGTERM"])
def test_ctrl_c_leaves_completed_outputs_and_no_half_written_ones(fleet_dir, tmp_path, how):
    """Ctrl-C at a terminal (SIGINT to the process group: the parent and its workers), or SIGTERM to the parent
    alone (kill, a container stopped): the parent interrupts its workers' running replays, which clean up; the
    logs done stay whole, and nothing half-written is left."""
    logs = [copy_log(fleet_dir / "a.mcap", tmp_path / f"run{i}.mcap") for i in range(8)]
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "navlog.cli", "-q", "replay", *map(str, logs), "--pipeline", "mapping"]
    argv += ["--set", "lidar_mapper=off", "--no-metrics", "--workers", "2", "-o", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(out.glob("*/manifest.json")):
        time.sleep(0.02)
    if how == "Ctrl-C":
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the parent and its workers
    else:
        proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == (130 if how == "Ctrl-C" else 143), err
    assert ("navlog: interrupted" if how == "Ctrl-C" else "navlog: terminated (SIGTERM)") in err
    assert "Traceback" not in err
    done = sorted(p.name for p in out.iterdir() if p.name != ".fleet")
    assert 1 <= len(done) < 8 and all(not name.startswith(".") for name in done)  # no temporary folder left
    records = sorted(p.name for p in (out / ".fleet").iterdir())
    assert set(records) <= {f"{name}.json" for name in done}  # no half-built folder (NAME.work) is left
    for name in done:
        manifest = json.loads((out / name / "manifest.json").read_text())
        for o in manifest["outputs"].values():
            from navlog.replay.identity import sha256_file

            assert sha256_file(out / name / o["file"]) == o["sha256"]


class _Interrupted:
    """An executor interrupted (Ctrl-C) before any log is done."""

    name = "interrupted"
    slots = 1

    def submit(self, key, fn, job) -> None:
        pass

    def wait(self):
        raise KeyboardInterrupt

    def close(self, *, cancel: bool = False, interrupt: bool = False) -> None:
        pass


def test_ctrl_c_before_any_log_is_done_leaves_no_output_folder(fleet_dir, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        replay_fleet([fleet_dir], "mapping", out, overrides=OVERRIDES, executor=_Interrupted(), progress=False)
    assert not out.exists()
    # a folder that was there before stays, with what it held
    out.mkdir()
    (out / "mine.txt").write_text("kept")
    with pytest.raises(KeyboardInterrupt):
        replay_fleet([fleet_dir], "mapping", out, overrides=OVERRIDES, executor=_Interrupted(), progress=False)
    assert (out / "mine.txt").read_text() == "kept"
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(KeyboardInterrupt):
        replay_fleet([fleet_dir], "mapping", empty, overrides=OVERRIDES, executor=_Interrupted(), progress=False)
    assert empty.is_dir()


def test_a_truncated_log_replayed_with_recover_gets_its_metrics_too(fleet_dir, tmp_path):
    """With --recover the truncated log's row was ok but its metrics blank: they were computed without recovery
    ('truncated ... use --recover'). They are computed on the part the replay read."""
    res = replay_fleet(
        [fleet_dir / "trunc.mcap"], "mapping", tmp_path / "out", overrides=OVERRIDES, recover=True, progress=False
    )
    (row,) = res.results
    assert row.status == "ok" and row.metrics_error == "", row.metrics_error
    assert row.metrics["trajectory.ate.pairs"] > 10 and 0 < row.metrics["trajectory.ate.translation_m.rmse"] < 0.1


def test_a_fleet_output_that_is_a_file_is_named_as_such(fleet_dir, tmp_path):
    """It was 'cannot write: File exists (a full disk or a file-size limit?)'."""
    afile = tmp_path / "afile"
    afile.write_text("keep\n")
    with pytest.raises(ConfigError, match=r"afile: is a file, not a folder; a fleet writes a folder per log"):
        replay_fleet(
            [fleet_dir / "a.mcap", fleet_dir / "b.mcap"], "mapping", afile, overrides=OVERRIDES, progress=False
        )
    assert afile.read_text() == "keep\n"
