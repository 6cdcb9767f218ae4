"""The fleet summary: one row per log and the totals, the same numbers in JSON, CSV and Markdown."""

from __future__ import annotations

import csv
import io
import json

from navlog.analysis.fleet.summary import summary_document, to_csv, to_json, to_markdown
from navlog.analysis.fleet.worker import LogResult

ATE = "trajectory.ate.translation_m.rmse"


def _results() -> list[LogResult]:
    ok = LogResult(
        "/logs/a.mcap",
        "a",
        "ok",
        duration_s=17.0,
        messages=1874,
        published={"/map": 9, "/map_metadata": 1},
        skipped={"scans within minimum travel (not inserted)": 131},
        outputs={"map.pgm": "1efe"},
        metrics={ATE: 0.025, "trajectory.ate.pairs": 40},
        wall_s=3.2,
    )
    cached = LogResult("/logs/b.mcap", "b", "ok", cached=True, duration_s=138.5, messages=15184, published={"/map": 70})
    failed = LogResult("/logs/c.mcap", "c", "failed", "c.mcap: not an MCAP | file", attempts=2)
    return [ok, cached, failed]


def test_totals_count_the_logs_and_add_up_their_numbers():
    doc = summary_document("mapping", _results(), version="9.9")
    assert doc["totals"] == {
        "logs": 3,
        "ok": 2,
        "failed": 1,
        "cached": 1,
        "duration_s": 155.5,
        "messages": 17058,
        "published": 80,
        "skipped": 131,
    }
    a = doc["logs"][0]
    assert (a["published"], a["skipped"], a["published_by_topic"]["/map"]) == (10, 131, 9)
    assert "wall_s" not in a and "peak_rss_mb" not in a  # nothing that varies from run to run
    assert json.loads(to_json(doc)) == doc


def test_csv_has_every_metric_as_a_column_and_a_total_line():
    rows = list(csv.reader(io.StringIO(to_csv(summary_document("mapping", _results(), version="9.9")))))
    header = rows[0]
    assert header[:3] == ["log", "output", "status"] and header[-1] == "reason"
    assert header[-3:-1] == ["trajectory.ate.pairs", ATE]  # every metric of any row, by name
    a, _, c, total = (dict(zip(header, row, strict=True)) for row in rows[1:])
    keys = ("output", "status", "duration_s", "messages", "published", "skipped", ATE, "trajectory.ate.pairs")
    assert [a[k] for k in keys] == ["a", "ok", "17.0", "1874", "10", "131", "0.025", "40"]
    assert [c[k] for k in (*keys, "attempts", "reason")] == [
        *("c", "failed", "0.0", "0", "0", "0", "", ""),
        *("2", "c.mcap: not an MCAP | file"),
    ]
    assert [total[k] for k in ("log", *keys[:5])] == ["TOTAL", "3 logs", "2 ok, 1 failed", "155.5", "17058", "80"]
    assert len(rows) == 5


def test_markdown_shows_the_headline_metrics_and_escapes_pipes():
    text = to_markdown(summary_document("mapping", _results(), version="9.9"))
    lines = text.splitlines()
    assert lines[0] == "# Fleet replay: 3 logs through 'mapping'"
    assert lines[2] == "| log | status | duration s | messages | published | skipped | ATE rmse m | reason |"
    assert lines[4] == "| a | ok | 17.00 | 1874 | 10 | 131 | 0.025 |  |"
    assert lines[5] == "| b | ok (cached) | 138.50 | 15184 | 70 | 0 |  |  |"
    assert lines[6] == "| c | failed | 0.00 | 0 | 0 | 0 |  | c.mcap: not an MCAP \\| file |"
    assert lines[7] == "| total (3 logs) | 2 ok, 1 failed | 155.50 | 17058 | 80 | 131 |  |  |"
