"""Campaign reports: the machine's figures apart from the deterministic rows, the contact sheet."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from navlog.campaign.report import MACHINE, contact_sheet_png, timing_summary, write_reports
from navlog.campaign.runner import cycle_time_ms
from navlog.recorder.generators import generate_world, write_world_yaml


def test_cycle_time_mean_and_p95_in_ms():
    seconds = [i / 1000 for i in range(1, 101)]  # 1..100 ms
    assert cycle_time_ms(seconds) == {"cycle_ms_mean": 50.5, "cycle_ms_p95": 95.05}
    assert cycle_time_ms([]) == {"cycle_ms_mean": None, "cycle_ms_p95": None}


def _row(i, variant, cycle_ms, wall_s, track=(), result="succeeded"):
    return {
        "run_id": f"corridor_0-go2-s{i}-r0-{variant}", "world": "corridor_0", "robot": "go2", "variant": variant,
        "seed": i, "route": 0, "start": [-2.0, 0.0, 0.0], "goal": [2.0, 0.0, 0.0], "difficulty": 0.3,
        "result": result, "time_s": 15.0 + i, "barn_metric": 0.1, "sim_s": 16.0, "cycles": 300,
        "cycle_ms_mean": cycle_ms, "cycle_ms_p95": 2 * cycle_ms, "wall_s": wall_s, "track": [list(p) for p in track],
        "key": "k", "path_length_m": 4.0, "min_clearance_m": 0.5, "recoveries": 0,
    }  # fmt: skip


def _summary(tmp_path, rows):
    from types import SimpleNamespace

    from navlog.campaign.stats import summarize

    gen = generate_world("corridor", 0, {"doors": 0, "length": 6.0})
    path = write_world_yaml(gen, tmp_path / "corridor_0.yaml")
    spec = SimpleNamespace(name="t", variants=[SimpleNamespace(name="a")], baseline_variant="a", alpha=0.05)
    return summarize(rows, spec, {"corridor_0": {"path": str(path)}})


def test_machine_figures_stay_out_of_the_deterministic_reports(tmp_path):
    rows = [_row(0, "a", 2.0, 10.0), _row(1, "a", 4.0, 12.0)]
    summary = _summary(tmp_path, rows)
    write_reports(tmp_path, rows, summary)
    text = (tmp_path / "campaign.json").read_text() + (tmp_path / "campaign.csv").read_text()
    assert not any(k in text for k in (*MACHINE, "track"))
    same = [dict(r, cycle_ms_mean=99.0, cycle_ms_p95=199.0, wall_s=1.0) for r in rows]  # another machine
    before = (tmp_path / "campaign.json").read_bytes()
    write_reports(tmp_path, same, summary)
    assert (tmp_path / "campaign.json").read_bytes() == before
    write_reports(tmp_path, rows, summary)
    timing = (tmp_path / "campaign_timing.csv").read_text().splitlines()
    assert timing[0] == "run_id,variant,result,cycles,cycle_ms_mean,cycle_ms_p95,wall_s"
    assert timing[1] == "corridor_0-go2-s0-r0-a,a,succeeded,300,2.0,4.0,10.0"
    t = timing_summary(rows, ["a"])["a"]
    assert (t["runs"], t["cycles"], t["cycle_ms_mean"], t["cycle_ms_p95"], t["cycle_ms_p95_max"], t["wall_s"]) == (
        2, 600, 3.0, 6.0, 8.0, 11.0)  # fmt: skip
    assert "| a | 2 | 600 | 3.00 | 6.00 | 8.00 | 11.0 |" in (tmp_path / "campaign_timing.md").read_text()


def _png_size(data):
    import matplotlib.image as mpimg

    return mpimg.imread(io.BytesIO(data)).shape[:2]


def test_the_contact_sheet_draws_each_run_that_did_not_succeed(tmp_path):
    track = [(-2.0 + 0.2 * k, 0.1 * np.sin(k)) for k in range(12)]
    rows = [_row(0, "a", 2.0, 10.0, track)] + [_row(i, "a", 2.0, 10.0, track[:6]) for i in range(1, 6)]
    for r, result in zip(rows, ["succeeded", "timeout", "collision", "aborted", "failed", "timeout"]):
        r["result"] = result
    summary = _summary(tmp_path, rows)
    sheet = contact_sheet_png(rows, summary)
    assert sheet[:4] == b"\x89PNG"
    assert _png_size(sheet) == (2 * 324, 4 * 306)  # 5 runs: 4 columns x 2 rows of 3.4 x 3.6 in at 90 dpi
    assert _png_size(contact_sheet_png(rows[:2], summary)) == (324, 306)  # one run, one panel
    assert contact_sheet_png(rows, summary) == sheet  # same rows, same bytes
    ok = contact_sheet_png(rows[:1], summary)
    assert _png_size(ok) == (324, 306)
    assert json.dumps(summary)  # the summary stays plain JSON


def test_the_contact_sheet_is_capped(tmp_path):
    rows = [_row(i, "a", 2.0, 10.0, result="timeout") for i in range(30)]
    assert _png_size(contact_sheet_png(rows, _summary(tmp_path, rows))) == (6 * 324, 4 * 306)  # 24 of 30


def test_generated_worlds_are_named_by_their_place_in_the_output_folder(tmp_path):
    """The reports' bytes must not depend on where OUT is: two folders, the same world entries."""
    from navlog.campaign.runner import plan_campaign
    from navlog.campaign.spec import load_campaign

    path = tmp_path / "c.yaml"
    path.write_text(
        "name: t\nworlds:\n  - {generate: corridor, count: 2, params: {doors: 0, length: 6.0}}\nrobots: [go2]\n"
        "variants:\n  - {name: a, nav2_params: nav_go2}\nroutes: {kind: fixed, start: [-2, 0, 0], goal: [2, 0, 0]}\n"
    )
    spec = load_campaign(path)
    one, two = (plan_campaign(spec, tmp_path, tmp_path / name).worlds for name in ("one", "deeper/two"))
    assert one == two
    assert one["corridor_1"]["path"] == "worlds/corridor_1.yaml"
    row = _row(0, "a", 2.0, 10.0, [(-2.0, 0.0), (-1.0, 0.0)], result="timeout") | {"world": "corridor_1"}
    summary = {"campaign": "t", "worlds": one}
    drawn = contact_sheet_png([row], summary, tmp_path / "one")  # the world found in OUT
    assert drawn != contact_sheet_png([row], {"campaign": "t", "worlds": {}})  # no world: no obstacles, no path


def test_worlds_named_by_config_name_or_gone_still_give_every_report(tmp_path):
    """A world given by its name (``indoor_room``) is not a file in OUT; one deleted since the runs cannot be
    drawn: the contact sheet draws the runs without it and every report is written."""
    track = [(-2.0 + 0.2 * k, 0.1 * np.sin(k)) for k in range(6)]
    rows = [_row(i, "a", 2.0, 10.0, track) for i in range(2)]
    for r in rows:
        r["result"] = "timeout"
    summary = _summary(tmp_path, rows)
    for path in ("indoor_room", str(tmp_path / "gone.yaml")):
        summary["worlds"]["corridor_0"]["path"] = path
        out = tmp_path / Path(path).stem
        out.mkdir()
        names = sorted(p.name for p in write_reports(out, rows, summary))
        assert "campaign.json" in names and "campaign_failures.png" in names, path
