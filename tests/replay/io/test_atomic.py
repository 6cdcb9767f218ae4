"""What a killed run leaves beside its output is cleared by the next run for the same output."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from navlog.replay.io.atomic import remove_stale, replace_output, temp_path, write_file


def dead_pid() -> int:
    """The PID of a process that has finished (and been reaped)."""
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_temporaries_of_finished_processes_are_removed_and_others_kept(tmp_path: Path) -> None:
    gone, alive = dead_pid(), os.getppid()
    out = tmp_path / "run.rrd"
    (tmp_path / f".run.rrd.{gone}.part").write_bytes(b"half")
    (tmp_path / f".run.rrd.{gone}.partial").mkdir()
    (tmp_path / f".run.rrd.{gone}.partial" / "map.pgm").write_bytes(b"half")
    (tmp_path / f".run.rrd.{alive}.part").write_bytes(b"a run writing now")
    (tmp_path / f".other.rrd.{gone}.part").write_bytes(b"another output's")
    (tmp_path / "run.rrd.notes").write_bytes(b"the user's")
    removed = remove_stale(out)
    assert sorted(p.name for p in removed) == [f".run.rrd.{gone}.part", f".run.rrd.{gone}.partial"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f".run.rrd.{alive}.part", f".other.rrd.{gone}.part", "run.rrd.notes"]
    )


def test_an_old_output_moved_aside_comes_back_when_the_final_name_is_empty(tmp_path: Path) -> None:
    gone = dead_pid()
    out = tmp_path / "bag"
    old = tmp_path / f".bag.old-{gone}"
    old.mkdir()
    (old / "metadata.yaml").write_text("previous\n")
    remove_stale(out)  # killed between moving the old output aside and moving the new one in
    assert (out / "metadata.yaml").read_text() == "previous\n" and not old.exists()
    old.mkdir()  # killed after both renames, before removing the old one
    remove_stale(out)
    assert not old.exists() and (out / "metadata.yaml").read_text() == "previous\n"


def test_a_stale_temporary_that_is_a_symlink_is_removed_as_a_link(tmp_path: Path) -> None:
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / "keep.txt").write_text("precious\n")
    (tmp_path / f".out.{dead_pid()}.part").symlink_to(target)
    remove_stale(tmp_path / "out")
    assert (target / "keep.txt").read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere"]


def test_temp_path_is_this_process_name_beside_the_output_and_clears_first(tmp_path: Path) -> None:
    out = tmp_path / "map.yaml"
    (tmp_path / f".map.yaml.{dead_pid()}.part").write_bytes(b"half")
    (tmp_path / f".map.yaml.{os.getpid()}.part").mkdir()  # a killed run that had this PID
    tmp = temp_path(out)
    assert tmp == tmp_path / f".map.yaml.{os.getpid()}.part"
    assert list(tmp_path.iterdir()) == []


def test_write_file_and_replace_output_leave_only_the_output(tmp_path: Path) -> None:
    out = tmp_path / "a.json"
    (tmp_path / f".a.json.{dead_pid()}.part").write_bytes(b"half")
    write_file(out, b"{}\n")
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"] and out.read_bytes() == b"{}\n"
    new = tmp_path / "new"
    new.mkdir()
    (tmp_path / "folder").mkdir()
    replace_output(new, tmp_path / "folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "folder"]


# ------------------------------------------------------------ one writer per output
def test_a_second_run_for_a_held_output_is_refused_naming_the_lock_and_the_holder(tmp_path: Path) -> None:
    import pytest

    from navlog.errors import NavlogError
    from navlog.replay.io.atomic import hold_output

    out = tmp_path / "rec.mcap"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from pathlib import Path; from navlog.replay.io.atomic import hold_output\n"
            f"with hold_output(Path({str(out)!r})):\n    print('held', flush=True); time.sleep(60)",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with (
            pytest.raises(
                NavlogError,
                match=rf"another navlog run \(pid {holder.pid}\) is writing this output \(lock .*\.rec\.mcap\.lock\)",
            ),
            hold_output(out),
        ):
            pass
    finally:
        holder.kill()
        holder.wait()
    # the holder was killed: its lock died with it, the file it left is taken over, and removed at the end
    assert (tmp_path / ".rec.mcap.lock").exists()
    with hold_output(out):
        assert (tmp_path / ".rec.mcap.lock").read_text().strip() == str(os.getpid())
    assert not (tmp_path / ".rec.mcap.lock").exists()


def test_the_commands_refuse_an_output_another_run_writes(tmp_path: Path, teleop_log: Path) -> None:
    """navlog replay and navlog record given the -o of a run in progress exit 2 and leave its files alone."""
    from navlog.replay.io.atomic import hold_output

    navlog = str(Path(sys.executable).parent / "navlog")
    out = tmp_path / "replay"
    rec = tmp_path / "rec.mcap"
    with hold_output(out), hold_output(rec):
        res = subprocess.run(
            [
                navlog,
                "-q",
                "replay",
                str(teleop_log),
                "--pipeline",
                "safety",
                "--remap",
                "/cmd_vel_nav=/cmd_vel",
                "-o",
                str(out),
            ],
            capture_output=True,
            text=True,
        )
        assert res.returncode == 2 and "is writing this output" in res.stderr, res.stderr
        res = subprocess.run(
            [navlog, "-q", "record", "--scenario", "teleop", "-o", str(rec)], capture_output=True, text=True
        )
        assert res.returncode == 2 and "is writing this output" in res.stderr, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_export_view_recover_fleet_and_campaign_refuse_an_output_another_run_writes(
    tmp_path: Path, teleop_log: Path, capsys
) -> None:
    """Every command that writes a whole output holds it: given the output of a run in progress, each exits 2
    naming the lock, and writes nothing."""
    from navlog.cli import main
    from navlog.replay.io.atomic import hold_output

    campaign = Path(__file__).parents[3] / "examples" / "campaigns" / "small.yaml"
    commands = {
        "bag": ["export", str(teleop_log), "--to", "rosbag2", "-o"],
        "view.rrd": ["view", str(teleop_log), "--save"],
        "fixed.mcap": ["recover", str(teleop_log), "-o"],
        "fleet": ["replay", str(teleop_log), str(teleop_log), "--pipeline", "mapping", "--workers", "1", "-o"],
        "campaign": ["campaign", "run", str(campaign), "-o"],
    }
    for name, argv in commands.items():
        out = tmp_path / name
        with hold_output(out):
            assert main(["-q", *argv, str(out)]) == 2, name
        assert "is writing this output" in capsys.readouterr().err, name
        assert not out.exists(), name
    assert list(tmp_path.iterdir()) == []


def test_a_write_error_moved_out_of_a_temporary_folder_names_the_final_path(tmp_path):
    from navlog.replay.io.atomic import WriteError

    tmp, final = tmp_path / ".out.partial", tmp_path / "out"
    err = WriteError(tmp / "maps" / "map.yaml", "cannot write map: No space left on device")
    assert str(err.moved(tmp, final)) == f"{final / 'maps' / 'map.yaml'}: cannot write map: No space left on device"
    elsewhere = WriteError(tmp_path / "other.yaml", "cannot write")
    assert elsewhere.moved(tmp, final) is elsewhere
    # a library's message naming the temporary path names the final one too; the error survives pickling
    # (a worker process's error reaches its parent)
    said = WriteError(tmp / "map.pcd", f"cannot write the point cloud ({tmp / 'map.pcd'} is full)").moved(tmp, final)
    assert str(said) == f"{final / 'map.pcd'}: cannot write the point cloud ({final / 'map.pcd'} is full)"
    import pickle

    again = pickle.loads(pickle.dumps(said))
    assert type(again) is WriteError and str(again) == str(said) and again.path == said.path


def test_no_command_replaces_what_it_reads_even_with_force(tmp_path: Path, teleop_log: Path, capsys, monkeypatch):
    """An output folder that holds the input log (replay, export to a bag, a fleet's per-log folder) or is the
    current folder, or an output file that is the input (export to TUM, recover, world-map), is refused with
    --force too, naming the input; the input and what lies beside it stay."""
    import shutil

    from navlog.cli import main

    folder = tmp_path / "runs"
    folder.mkdir()
    log = folder / "teleop.mcap"
    shutil.copyfile(teleop_log, log)
    (folder / "notes.txt").write_text("keep\n")
    mapping = ["--pipeline", "mapping", "--set", "lidar_mapper=off"]
    refused = {
        "holds the input": [
            ["replay", str(log), *mapping, "-o", str(folder), "--force"],
            ["export", str(log), "--to", "rosbag2", "-o", str(folder), "--force"],
        ],
        "is the input": [
            ["export", str(log), "--to", "tum", "--topic", "/odom", "-o", str(log), "--force"],
            ["recover", str(log), "-o", str(folder / "." / "teleop.mcap"), "--force"],
        ],
    }
    for words, commands in refused.items():
        for argv in commands:
            code = main(["-q", *argv])
            err = capsys.readouterr().err
            assert code == 2 and words in err and str(log) in err, (argv, err)
    # a fleet writes each log's replay to OUT/NAME: a log inside that folder is its failed row, left as it was
    fleet = tmp_path / "fleet"
    (fleet / "teleop").mkdir(parents=True)
    inner = fleet / "teleop" / "teleop.mcap"
    shutil.copyfile(teleop_log, inner)
    assert main(["-q", "replay", str(inner), *mapping, "--workers", "1", "-o", str(fleet), "--force"]) == 1
    assert "holds the input" in (fleet / "fleet-summary.md").read_text()
    assert inner.read_bytes() == teleop_log.read_bytes()
    world = tmp_path / "room.yaml"
    world.write_text(
        "image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\noccupied_thresh: 0.65\nfree_thresh: 0.25\n"
        "negate: 0\n"
    )
    (tmp_path / "room.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes([0] * 4 + [254] * 12))
    assert main(["-q", "world-map", str(world), "-o", str(world), "--force"]) == 2
    assert "is the input" in capsys.readouterr().err
    monkeypatch.chdir(folder)
    assert main(["-q", "replay", "teleop.mcap", *mapping, "-o", ".", "--force"]) == 2
    assert ".: is (or holds) the current folder" in capsys.readouterr().err
    monkeypatch.chdir(fleet / "teleop")  # a replay into the folder it runs from
    assert main(["-q", "replay", str(log), *mapping, "-o", str(fleet), "--force"]) == 2
    assert "is (or holds) the current folder" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt", "teleop.mcap"]
    assert log.read_bytes() == teleop_log.read_bytes()


def test_inputs_other_than_the_log_linked_or_holding_the_output_are_not_replaced_either(
    tmp_path: Path, teleop_log: Path, capsys, monkeypatch
):
    """A parameter file in the output folder, a log read through a link in it (the folder and what lies beside
    the link), a map's image that world-map's PGM would be, and a file written inside an input bag folder are
    refused, naming the input."""
    import shutil

    from navlog.cli import main

    monkeypatch.chdir(tmp_path)
    mapping = ["--pipeline", "mapping", "--set", "lidar_mapper=off"]
    (tmp_path / "out").mkdir()
    shutil.copyfile(Path(__file__).parents[3] / "config" / "pipelines" / "mapping.yaml", "out/params.yaml")
    assert main(["-q", "replay", str(teleop_log), *mapping, "--params", "out/params.yaml", "-o", "out", "--force"]) == 2
    assert "out: holds the input out/params.yaml" in capsys.readouterr().err
    (tmp_path / "linked").mkdir()
    (tmp_path / "linked" / "run.mcap").symlink_to(teleop_log)
    (tmp_path / "linked" / "notes.txt").write_text("keep\n")
    assert main(["-q", "replay", "linked/run.mcap", *mapping, "-o", "linked", "--force"]) == 2
    assert "linked: holds the input linked/run.mcap" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "linked").iterdir()) == ["notes.txt", "run.mcap"]
    (tmp_path / "room.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes([0] * 4 + [254] * 12))
    (tmp_path / "room.yaml").write_text(
        "image: room.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n"
    )
    assert main(["-q", "world-map", "room.yaml", "-o", "room.yml", "--force"]) == 2
    assert "room.pgm: is the input" in capsys.readouterr().err
    assert main(["-q", "export", str(teleop_log), "--to", "rosbag2", "-o", "bag"]) == 0
    capsys.readouterr()
    (db3,) = (tmp_path / "bag").glob("*.db3")
    before = db3.read_bytes()
    assert main(["-q", "export", "bag", "--to", "tum", "--topic", "/odom", "-o", f"bag/{db3.name}", "--force"]) == 2
    assert f"bag/{db3.name}: lies inside the input bag" in capsys.readouterr().err
    assert db3.read_bytes() == before


def test_a_write_error_hints_at_its_cause_by_errno(tmp_path: Path) -> None:
    """A missing folder on the way or a folder where a file goes is not said to be a full disk."""
    import errno

    from navlog.replay.io.atomic import write_error

    for code in (errno.ENOENT, errno.ENOTDIR, errno.EISDIR):
        said = str(write_error(tmp_path / "out.x", OSError(code, os.strerror(code))))
        assert "full disk" not in said and "a folder on the way missing, or a file where a folder is?" in said
    assert "a full disk or a file-size limit?" in str(write_error(tmp_path / "x", OSError(errno.ENOSPC, "No space")))
    assert "a read-only folder?" in str(write_error(tmp_path / "x", OSError(errno.EROFS, "Read-only")))
