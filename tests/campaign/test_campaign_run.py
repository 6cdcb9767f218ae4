"""The shipped small campaign end to end: 12 recorded runs, their statistics, resumption."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.campaign.runner import run_campaign
from navlog.campaign.stats import REGRESSED

SMALL = Path(__file__).parents[2] / "examples" / "campaigns" / "small.yaml"


@pytest.mark.slow
def test_half_speed_is_regressed_on_time_and_a_rerun_reuses_every_run(tmp_path):
    out = tmp_path / "out"
    res = run_campaign(SMALL, out, workers=2, progress=False)
    assert len(res.rows) == 12 and res.cached == 0
    assert [r["result"] for r in res.rows] == ["succeeded"] * 12
    base, half = res.summary["variants"]["baseline"], res.summary["variants"]["half_speed"]
    assert base["success_rate"] == half["success_rate"] == 1.0
    assert base["success_ci"] == pytest.approx([0.6097, 1.0], abs=1e-4)  # Wilson, 6 of 6
    assert half["time_s"]["mean"] > 1.4 * base["time_s"]["mean"]
    c = res.summary["comparisons"]["half_speed"]
    assert c["pairs"] == 6 and c["verdict"] == REGRESSED and c["worse"] == ["time_s"]
    assert c["time_s"]["p_value"] == pytest.approx(2 / 2**6)  # all six pairs slower: the exact test's floor
    for r in res.rows:  # each run's path is the optimal path's length give or take the goal tolerance
        assert 0.8 * r["optimal_path_m"] < r["path_length_m"] < 1.5 * r["optimal_path_m"]
        assert r["min_clearance_m"] > 0.22 and r["collisions"] == 0
        # the controller cycles at 20 Hz until the goal: one cycle per 50 ms of the run's time to the goal
        assert r["cycles"] == pytest.approx(r["time_s"] * 20, abs=25)
        # (one slow first cycle, numba loading its kernels, can lift the mean past the p95)
        assert 0 < r["cycle_ms_mean"] < 1000 and 0 < r["cycle_ms_p95"] < 1000
    assert "cycle_ms" not in (out / "campaign.json").read_text()  # the machine's figures: campaign_timing.*
    assert (out / "campaign_timing.csv").read_text().count("\n") == 13
    report = (out / "campaign.json").read_bytes()
    assert (out / "campaign.csv").read_text().count("\n") == 13
    assert (out / "campaign.png").read_bytes()[:4] == b"\x89PNG"
    again = run_campaign(SMALL, out, workers=1, progress=False)
    assert again.cached == 12
    assert (out / "campaign.json").read_bytes() == report
    assert not (out / "logs").exists()  # logs only when asked


@pytest.mark.slow
def test_a_robot_given_as_a_path_runs_and_an_edit_to_it_redoes_its_runs(tmp_path):
    """A robot YAML given by path named its run files with the path's slash (every run failed), a rerun after
    the robot's top speed was halved reused the old rows (their key held the robot's name only), and a rerun
    with --keep-logs reused rows without logs and kept none."""
    from navlog.replay.config import named_config

    robot = tmp_path / "robots" / "go2x.yaml"
    robot.parent.mkdir()
    go2 = named_config("robots", "go2").read_text()
    robot.write_text(go2.replace("name: go2", "name: go2x", 1))
    text = SMALL.read_text().replace("robots: [go2]", f"robots: [{robot}]").replace("count: 3", "count: 1")
    text = text.replace("seeds: [0, 1]", "seeds: [0]").replace("max_duration: 90", "max_duration: 60")
    campaign = tmp_path / "c.yaml"
    campaign.write_text(text.split("  - {name: half_speed")[0] + text[text.index("routes:") :])
    out = tmp_path / "out"
    first = run_campaign(campaign, out, workers=1, progress=False)
    assert [(r["result"], r["run_id"].split("-")[1]) for r in first.rows] == [("succeeded", "go2x")]
    assert "max_vx: 0.3" in go2
    robot.write_text(robot.read_text().replace("max_vx: 0.3", "max_vx: 0.15", 1))
    again = run_campaign(campaign, out, workers=1, progress=False)
    assert again.cached == 0 and again.rows[0]["time_s"] > 1.3 * first.rows[0]["time_s"]
    # a rerun asking for logs records again the runs whose log it has not (it reused them and kept none)
    logged = run_campaign(campaign, out, workers=1, progress=False, keep_logs="all")
    assert logged.cached == 0 and (out / logged.rows[0]["log"]).is_file()
    assert run_campaign(campaign, out, workers=1, progress=False, keep_logs="all").cached == 1
