"""Bad campaign input fails before anything runs; infeasible routes are rows, not failures; Ctrl-C keeps
every finished row whole."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from navlog.campaign.runner import _cached_row, plan_campaign, run_campaign
from navlog.campaign.spec import load_campaign
from navlog.campaign.stats import variant_summary
from navlog.errors import ConfigError
from tests.campaign.campaign_files import BASE, write


def test_an_impossible_field_is_an_error_before_any_run(tmp_path):
    text = BASE.replace(
        "{generate: corridor, count: 1, params: {doors: 0, length: 6.0}}", "{generate: barn, params: {fill: 1.0}}"
    )
    with pytest.raises(ConfigError, match=r"worlds\[0\].*fill must be at least 0 and below 1"):
        run_campaign(write(tmp_path, text), tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out" / "runs").exists()


def test_an_unreachable_goal_is_an_infeasible_row_left_out_of_the_success_rate(tmp_path):
    # two 6 m corridors, one with a cross wall whose 0.3 m doorway the Go2 (radius 0.22 m) cannot pass
    text = (
        BASE.replace(
            "  - {generate: corridor, count: 1, params: {doors: 0, length: 6.0}}\n",
            "  - {generate: corridor, count: 1, params: {doors: 0, length: 6.0}}\n"
            "  - {generate: corridor, count: 1, seed: 1, params: {doors: 1, door_width: 0.3, length: 6.0}}\n",
        )
        + "routes: {kind: fixed, start: [-2.0, 0, 0], goal: [2.0, 0, 0]}\n"
    )
    spec = load_campaign(write(tmp_path, text))
    plan = plan_campaign(spec, tmp_path, tmp_path / "out")
    assert [j.world for j in plan.jobs] == ["corridor_0"]
    assert plan.jobs[0].optimal_path_m == pytest.approx(4.0, abs=0.1)
    (bad,) = plan.infeasible
    assert bad["world"] == "corridor_1" and bad["result"] == "infeasible"
    assert bad["message"] == "no path reaches the goal"
    done = {"run_id": "x", "variant": "a", "result": "succeeded", "time_s": 14.0, "barn_metric": 0.2, "sim_s": 15.0}
    s = variant_summary([done, bad])
    assert (s["runs"], s["infeasible"], s["success_rate"]) == (1, 1, 1.0)  # 1 of 1, not 1 of 2


@pytest.mark.parametrize(
    "text, message",
    [
        (
            BASE.replace("nav2_params: nav_go2", "nav2_param: nav_go2"),
            r"variants\[0\]\.nav2_param: unknown key \(did you mean 'nav2_params'\?\)",
        ),
        (BASE.replace("name: a,", "name: a, sett: [],"), r"variants\[0\]\.sett: unknown key \(did you mean 'set'\?\)"),
        (BASE + "seeds: []\n", r"worlds, robots, variants and seeds must each list at least one entry"),
        # (a seed past 32 bits failed every run, each in the navigation pipeline's own check)
        (BASE + "seeds: [4294967296]\n", r"seeds\[0\]: 4294967296: seeds must be unique integers from 0 to 4294967295"),
        (BASE + "seeds: [0, 3, -1]\n", r"seeds\[2\]: -1: seeds must be unique integers"),
        (BASE + "seeds: [0, 3, 0]\n", r"seeds\[2\]: 0 is seeds\[0\] again: seeds must be unique"),
        (BASE.replace("robots: [go2]", "robots: []"), r"worlds, robots, variants and seeds must each list"),
    ],
)
def test_bad_variant_keys_and_empty_campaigns_are_refused(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message):
        run_campaign(write(tmp_path, text), tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out").exists()


def test_an_unknown_variant_to_run_is_refused_with_a_did_you_mean(tmp_path):
    with pytest.raises(ConfigError, match=r"--variant 'b' is not a variant of 't'; variants: a"):
        run_campaign(write(tmp_path, BASE), tmp_path / "out", workers=1, progress=False, only=["b"])
    text = BASE + "  - {name: slow, nav2_params: nav_go2}\n"
    with pytest.raises(ConfigError, match=r"--variant 'slwo' .*did you mean 'slow'"):
        run_campaign(write(tmp_path, text), tmp_path / "out", workers=1, progress=False, only=["slwo"])


@pytest.mark.slow
def test_ctrl_c_during_the_pool_leaves_every_finished_row_whole(tmp_path):
    """SIGINT to the campaign's process group (a terminal's Ctrl-C) while 2 workers run: exit 130 without
    a traceback, every row in OUT/runs is a whole JSON a rerun reuses, no temporary or report file."""
    text = BASE + "routes: {kind: fixed, start: [-2.0, 0, 0], goal: [2.0, 0, 0]}\nseeds: [0, 1, 2, 3, 4, 5, 6, 7]\n"
    campaign, out = write(tmp_path, text), tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "navlog.cli", "campaign", "run", str(campaign), "-o", str(out), "--workers", "2", "-q"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    while not list(out.glob("runs/*.json")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    assert proc.poll() is None, "the campaign ended before a row was written"
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err.decode()
    assert b"Traceback" not in err and b"navlog: interrupted" in err
    rows = sorted(out.glob("runs/*"))
    assert 1 <= len(rows) < 8
    jobs = {j.run_id: j for j in plan_campaign(load_campaign(campaign), tmp_path, tmp_path / "plan").jobs}
    for path in rows:
        row = json.loads(path.read_text())
        assert row["result"] == "succeeded", row
        assert _cached_row(path, jobs[path.stem].key) is not None  # the rerun reuses it
    left = sorted(p.name for p in out.rglob("*") if p.is_file() and p.parent.name not in ("runs", "worlds", "variants"))
    assert left == [], left  # no half-written report, no temporary file
    assert not [p for p in out.rglob("*") if p.name.startswith(".") or p.suffix in (".tmp", ".part")]


def test_a_campaign_refused_while_planned_names_its_file_and_leaves_no_folder(tmp_path):
    """An unknown robot (found only once the campaign is planned) was said without the campaign file, and left
    OUT/ with its worlds/ and variants/ made."""
    campaign = write(tmp_path, BASE.replace("robots: [go2]", "robots: [go3]"))
    with pytest.raises(ConfigError, match=rf"^{campaign}: robots\[0\]: unknown robot 'go3' \(did you mean 'go2'\?\)"):
        run_campaign(campaign, tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out").exists()
