"""A recipe's log on another machine: other bytes (its floating point rounds otherwise), the same layout
(topics, schemas, message times and sizes); the recipe check passes on the layout only for the
baseline's own recipe, and a changed layout fails it."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from mcap.writer import Writer

from navlog.analysis.ci.baselines import Baseline
from navlog.analysis.ci.cache import log_layout_sha256
from navlog.analysis.ci.result import Status
from navlog.analysis.ci.runner import _provenance_checks
from navlog.analysis.ci.suite import Recipe
from navlog.errors import NavlogError
from navlog.replay.identity import log_sha256

RECIPE = Recipe("walled_room", "kibot", "teleop_wall", 0, True)


def write_log(path: Path, values: list[float], extra_topic: bool = False) -> Path:
    """One float64 message a second on /odom (and one on /extra when asked)."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema("nav_msgs/msg/Odometry", "ros2msg", b"float64 x")
        odom = w.register_channel("/odom", "cdr", schema)
        for k, v in enumerate(values):
            w.add_message(odom, log_time=k * 10**9, publish_time=k * 10**9, data=struct.pack("<d", v))
        if extra_topic:
            extra = w.register_channel("/extra", "cdr", schema)
            w.add_message(extra, log_time=10**9, publish_time=10**9, data=struct.pack("<d", 0.0))
        w.finish()
    return path


def test_the_layout_ignores_the_values_and_sees_topics_times_and_sizes(tmp_path):
    a = write_log(tmp_path / "a.mcap", [0.1, 0.2, 0.3])
    b = write_log(tmp_path / "b.mcap", [0.1, 0.2 + 2**-54, 0.3])  # one value rounded otherwise
    assert log_sha256(a) != log_sha256(b)
    assert log_layout_sha256(a) == log_layout_sha256(b)
    assert log_layout_sha256(write_log(tmp_path / "c.mcap", [0.1, 0.2])) != log_layout_sha256(a)
    assert log_layout_sha256(write_log(tmp_path / "d.mcap", [0.1, 0.2, 0.3], True)) != log_layout_sha256(a)
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(a.read_bytes()[:40])
    with pytest.raises(NavlogError, match=r"broken\.mcap: cannot read the log's messages"):
        log_layout_sha256(broken)


def case(recipe: Recipe):
    class Case:  # what the recipe check reads of a case
        pass

    c = Case()
    c.recipe = recipe  # type: ignore[attr-defined]
    return c


def baseline(sha: str, layout: str | None, recipe: Recipe = RECIPE) -> Baseline:
    log = {"sha256": sha, "recipe": recipe.to_dict()} | ({"layout": layout} if layout else {})
    return Baseline(Path("."), {"provenance": {"log": log, "navlog_version": "0.1.0", "parameter_hash": "p"}})


def recipe_check(base: Baseline, sha: str, layout: str, recipe: Recipe = RECIPE):
    provenance = {"log": {"sha256": sha, "layout": layout, "recipe": recipe.to_dict()}, "parameter_hash": "p"}
    return next(c for c in _provenance_checks(case(recipe), base, provenance, []) if c.kind == "recipe")


def test_the_recipe_check_passes_on_the_same_bytes_or_the_same_layout_only():
    assert recipe_check(baseline("s1", "L"), "s1", "L").status is Status.PASS
    other_machine = recipe_check(baseline("s1", "L"), "s2", "L")
    assert other_machine.status is Status.PASS and "same topics, message times and sizes" in other_machine.message
    assert recipe_check(baseline("s1", "L"), "s2", "M").status is Status.FAIL  # the recorder changed
    assert recipe_check(baseline("s1", None), "s2", "L").status is Status.FAIL  # a baseline without a layout
    seed = Recipe("walled_room", "kibot", "teleop_wall", 1, True)  # another seed: the same layout, not the same log
    assert recipe_check(baseline("s1", "L"), "s2", "L", seed).status is Status.FAIL


def test_on_a_machine_that_rounds_otherwise_only_hash_only_outputs_go_unjudged(tmp_path):
    """The baseline keeps replay.mcap as a hash and a trajectory it can compare: with the log recorded
    with other bytes (same layout), replay.mcap's other bytes pass as not judged, saying why; the
    trajectory is still compared, and fails beyond its tolerance. On the baseline's own log, other
    replay.mcap bytes are information too (no tolerance can judge them), never a failure."""
    from navlog.analysis.ci.baselines import compare_to_baseline, read_baseline, write_baseline
    from navlog.analysis.diff.tolerances import DEFAULT_TOLERANCES

    def outputs(folder: Path, mcap: bytes, x: float) -> dict[str, Path]:
        folder.mkdir()
        (folder / "replay.mcap").write_bytes(mcap)
        (folder / "trajectory.tum").write_text("".join(f"{k}.0 {x + k} 0 0 0 0 0 1\n" for k in range(5)))
        return {"replay.mcap": folder / "replay.mcap", "trajectory.tum": folder / "trajectory.tum"}

    write_baseline(tmp_path / "base", outputs(tmp_path / "a", b"one", 0.0), {"log": {}}, label="case")
    base = read_baseline(tmp_path / "base")
    assert base is not None

    def statuses(mcap: bytes, x: float, rounds: bool) -> dict[str, tuple[Status, str]]:
        folder = tmp_path / f"{mcap.decode()}-{x}-{rounds}"
        found = compare_to_baseline(base, outputs(folder, mcap, x), DEFAULT_TOLERANCES, log_rounds_otherwise=rounds)
        return {c.name: (c.status, c.message) for c in found}

    other = statuses(b"two", 0.0, rounds=True)
    assert other["replay.mcap"][0] is Status.PASS and "not judged" in other["replay.mcap"][1]
    assert other["trajectory.tum"][0] is Status.PASS
    assert "this machine rounds otherwise" in other["replay.mcap"][1]
    own = statuses(b"two", 0.0, rounds=False)["replay.mcap"]
    assert own[0] is Status.PASS and "not judged" in own[1] and "rounds otherwise" not in own[1]
    assert statuses(b"two", 5.0, rounds=True)["trajectory.tum"][0] is Status.FAIL  # moved 5 m: still judged
    assert statuses(b"one", 0.0, rounds=True)["replay.mcap"] == (Status.PASS, "same bytes")
