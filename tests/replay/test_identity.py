"""The replay identity: one key for a log, a pipeline, its parameters, the remaps and navlog's version."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

from navlog.replay.identity import input_entries, inputs_sha256, log_sha256, parameter_hash, replay_identity
from navlog.version import __version__


@dataclass(frozen=True)
class Inner:
    resolution: float = 0.05
    nav2_params: str = ""


@dataclass(frozen=True)
class Params:
    mode: str = "auto"
    inner: Inner = Inner()


def canonical(data: object) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def test_the_key_is_the_sha256_of_the_canonical_json_the_ci_cache_has_always_named_its_replays_by():
    log = "ab" * 32
    params_hash = canonical({"inner": {"nav2_params": "", "resolution": 0.05}, "mode": "auto"})
    assert parameter_hash(Params()) == params_hash
    want = canonical(
        {
            "pipeline": "mapping",
            "log": log,
            "parameters": params_hash,
            "remap": {"/a": "/x", "/b": "/y"},
            "navlog_version": __version__,
        }
    )
    # the remaps in any order give one key
    assert replay_identity(log, "mapping", Params(), {"/b": "/y", "/a": "/x"}) == want
    assert replay_identity(log, "mapping", Params(), {"/a": "/x", "/b": "/y"}) == want


def test_every_input_of_the_key_changes_it():
    log = "ab" * 32
    base = replay_identity(log, "mapping", Params(), {})
    others = {
        replay_identity("cd" * 32, "mapping", Params(), {}),
        replay_identity(log, "planner", Params(), {}),
        replay_identity(log, "mapping", Params(inner=Inner(resolution=0.1)), {}),
        replay_identity(log, "mapping", Params(), {"/scan": "/stable_scan"}),
        replay_identity(log, "mapping", Params(), {}, navlog_version="0.0.0"),
    }
    assert base not in others and len(others) == 5


def test_a_parameter_naming_a_file_counts_by_its_content_not_its_path(tmp_path):
    a, b = tmp_path / "a" / "nav2.yaml", tmp_path / "b" / "nav2.yaml"
    for p in (a, b):
        p.parent.mkdir()
        p.write_text("planner_server: {}\n")
    key_a = replay_identity("ab" * 32, "planner", Params(inner=Inner(nav2_params=str(a))), {})
    assert key_a == replay_identity("ab" * 32, "planner", Params(inner=Inner(nav2_params=str(b))), {})
    b.write_text("planner_server: {ros__parameters: {expected_planner_frequency: 2.0}}\n")
    assert key_a != replay_identity("ab" * 32, "planner", Params(inner=Inner(nav2_params=str(b))), {})


def test_a_logs_hash_from_its_files_as_a_manifest_lists_them(tmp_path):
    log = tmp_path / "run.mcap"
    log.write_bytes(b"\x89MCAP0\r\n" + bytes(100))
    entries = input_entries(log)
    assert entries == [{"file": "run.mcap", "bytes": 108, "sha256": hashlib.sha256(log.read_bytes()).hexdigest()}]
    assert log_sha256(log) == inputs_sha256(entries, folder=False) == entries[0]["sha256"]
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (bag / "bag_0.db3").write_bytes(bytes(10))
    pairs = [[e["file"], e["sha256"]] for e in input_entries(bag)]
    assert [p[0] for p in pairs] == ["bag_0.db3", "metadata.yaml"]
    assert log_sha256(bag) == canonical(pairs) != log_sha256(bag / "bag_0.db3")


def test_input_digests_are_sha256_of_the_whole_file(tmp_path):
    import hashlib

    from navlog.replay.identity import sha256_file

    for size in (0, 1, 4097, (1 << 20) + 3):
        p = tmp_path / f"f{size}"
        data = bytes(range(256)) * (size // 256) + bytes(size % 256)
        p.write_bytes(data)
        assert sha256_file(p) == hashlib.sha256(data).hexdigest()


def test_hashing_a_log_keeps_memory_flat(tmp_path, monkeypatch):
    """The digest is read block by block (block edges included): hashing a 96 MiB file raises the process's
    peak resident size by about a block, not by the file (a memory map of it would count it all)."""
    import hashlib
    import subprocess
    import sys

    from navlog.replay import identity

    monkeypatch.setattr(identity, "HASH_BLOCK", 4096)
    for size in (4095, 4096, 4097, 3 * 4096 + 5):
        p = tmp_path / f"g{size}"
        data = bytes((i * 7) % 251 for i in range(size))
        p.write_bytes(data)
        assert identity.sha256_file(p) == hashlib.sha256(data).hexdigest()
    big = tmp_path / "big.bin"
    with open(big, "wb") as f:
        for k in range(96):
            f.write(bytes([k]) * (1 << 20))
    code = (
        "import resource, sys; from navlog.replay.identity import sha256_file; "
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss; "
        "digest = sha256_file(sys.argv[1]) if sys.argv[2] == '1' else ''; "
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before, digest)"
    )
    grew, digest = subprocess.run(
        [sys.executable, "-c", code, str(big), "1"], capture_output=True, text=True, check=True
    ).stdout.split()
    assert digest == hashlib.sha256(big.read_bytes()).hexdigest()
    assert int(grew) < 40 * 1024  # KiB: a 16 MiB block and the interpreter's own, far from 96 MiB
