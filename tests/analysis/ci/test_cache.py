"""The CI cache names a replay by its identity: the key ``run_replay`` gives and a fleet's resume check keeps."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from navlog.analysis.ci import run_suite
from navlog.analysis.fleet import replay_fleet
from navlog.replay.identity import log_sha256, replay_identity
from navlog.replay.session import pipeline_params, run_replay

OVERRIDES = ["lidar_mapper=off"]  # the 2D mapper only: about a second on the teleop log


def test_a_replay_run_alone_by_a_fleet_and_by_ci_has_one_identity(teleop_log: Path, tmp_path: Path) -> None:
    params = pipeline_params("mapping", overrides=OVERRIDES)
    key = replay_identity(log_sha256(teleop_log), "mapping", params, {})
    alone = run_replay(teleop_log, "mapping", tmp_path / "alone", params=params, progress=False)
    assert alone.identity == key

    fleet = replay_fleet([teleop_log], "mapping", tmp_path / "fleet", overrides=OVERRIDES, workers=1, progress=False)
    name = fleet.results[0].name
    assert json.loads((tmp_path / "fleet" / ".fleet" / f"{name}.json").read_text())["key"] == key

    suite = tmp_path / "one.navlog-suite.yaml"
    suite.write_text(f"cases:\n  - {{name: m, pipeline: mapping, log: {teleop_log}, overrides: [lidar_mapper=off]}}\n")
    cache = tmp_path / "cache"
    first = run_suite(suite, cache_dir=cache, baseline_dir=tmp_path / "b")
    assert [p.name for p in (cache / "replays").iterdir()] == [key]
    assert not first.case("m").replay_cached
    assert run_suite(suite, cache_dir=cache, baseline_dir=tmp_path / "b").case("m").replay_cached
    rerun = replay_fleet([teleop_log], "mapping", tmp_path / "fleet", params=params, workers=1, progress=False)
    assert rerun.results[0].cached
    # the three made the same bytes
    for out in (tmp_path / "alone", tmp_path / "fleet" / name, cache / "replays" / key):
        assert (out / "map.pgm").read_bytes() == (tmp_path / "alone" / "map.pgm").read_bytes()

    # a changed parameter is another replay for each of them
    changed = pipeline_params("mapping", overrides=[*OVERRIDES, "occupancy.grid.resolution=0.1"])
    assert replay_identity(log_sha256(teleop_log), "mapping", changed, {}) != key
    again = replay_fleet([teleop_log], "mapping", tmp_path / "fleet", params=changed, workers=1, progress=False)
    assert not again.results[0].cached
    state = json.loads((tmp_path / "fleet" / ".fleet" / f"{name}.json").read_text())
    assert state["key"] == replay_identity(log_sha256(teleop_log), "mapping", changed, {}) != key


def test_a_replay_another_worker_put_in_place_meanwhile_is_kept_not_deleted_under_it(
    teleop_log: Path, tmp_path: Path, monkeypatch
) -> None:
    # two cases with the same log and parameters, on two workers: the second to finish deleted the first's
    # replay while the first was reading its outputs
    import navlog.replay.session as session
    from navlog.analysis.ci import cache

    params = pipeline_params("mapping", overrides=OVERRIDES)
    key = replay_identity(log_sha256(teleop_log), "mapping", params, {})
    placed = tmp_path / "cache" / "replays" / key
    real = session.run_replay

    def other_worker_finishes_first(log, pipeline, out, **kw):
        run = real(log, pipeline, out, **kw)
        real(log, pipeline, placed, **kw)  # the other worker's replay lands while this one finishes
        (placed / "being-read").write_text("the other case reads this folder now")
        return run

    monkeypatch.setattr(session, "run_replay", other_worker_finishes_first)
    with cache.cached_replay(teleop_log, "mapping", params, {}, key, tmp_path / "cache") as (out, cached):
        assert out == placed and not cached
    assert (placed / "being-read").is_file() and (placed / "manifest.json").is_file()
    assert sorted(p.name for p in placed.parent.iterdir()) == [key]  # its own copy gone, nothing half-written

    # a fresh replay (--determinism) is read from its own folder: the one in place, which another case may be
    # reading, is neither replaced nor deleted, and the fresh one leaves nothing beside it
    monkeypatch.setattr(session, "run_replay", real)
    with cache.cached_replay(teleop_log, "mapping", params, {}, key, tmp_path / "cache", fresh=True) as (out, _):
        assert out != placed and (out / "manifest.json").is_file() and not (out / "being-read").exists()
        own = json.loads((out / "manifest.json").read_text())["outputs"]
    assert (placed / "being-read").is_file() and sorted(p.name for p in placed.parent.iterdir()) == [key]
    assert own == json.loads((placed / "manifest.json").read_text())["outputs"]  # the same bytes either way

    # where none is in place, the fresh replay is put there at the end
    shutil.rmtree(placed)
    with cache.cached_replay(teleop_log, "mapping", params, {}, key, tmp_path / "cache", fresh=True) as (out, _):
        assert out != placed and not placed.exists()
    assert (placed / "manifest.json").is_file() and sorted(p.name for p in placed.parent.iterdir()) == [key]
