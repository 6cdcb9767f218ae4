"""Progress on stderr and summary tables: a line per decile off a terminal, a rich bar on one."""

from __future__ import annotations

import io

import pytest

from navlog.replay.runtime.progress import Progress, format_table

DECILES = [f"recording: {d}%" for d in range(0, 101, 10)]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_off_a_terminal_every_decile_is_printed_up_to_100_percent():
    out = io.StringIO()
    with Progress(138.0, "recording", "sim s", file=out) as bar:
        for t in range(1, 139):
            bar.update(float(t))
    assert out.getvalue().splitlines() == DECILES


def test_a_run_shorter_than_its_estimate_still_reaches_100_percent():
    # a 138 s tour with a 400 s estimate stopped at 30 %: the finished run corrects the total
    out = io.StringIO()
    with Progress(400.0, "recording", "sim s", file=out) as bar:
        for t in range(1, 139):
            bar.update(float(t))
        assert out.getvalue().splitlines() == DECILES[:4]
        bar.update(138.0, total=138.0)
    assert out.getvalue().splitlines() == DECILES


def test_a_jump_prints_the_deciles_it_skips_once_each():
    out = io.StringIO()
    bar = Progress(10.0, "x", file=out)
    bar.update(2.5)
    bar.update(2.6)
    bar.update(100.0)
    bar.close()
    bar.update(5.0)  # after close: nothing
    assert out.getvalue().splitlines() == [f"x: {d}%" for d in range(0, 101, 10)]


def test_disabled_prints_nothing():
    out = _Terminal()
    with Progress(10.0, "x", enabled=False, file=out) as bar:
        bar.update(5.0)
    assert out.getvalue() == ""


def test_on_a_terminal_a_rich_bar_shows_label_percentage_amount_and_rate():
    out = _Terminal()
    with Progress(10.0, "replay mapping", "log s", file=out) as bar:
        for t in range(1, 11):
            bar.update(float(t))
    text = out.getvalue()
    assert "replay mapping" in text and "100%" in text and "10.0/10.0 log s" in text
    assert "log s/s" in text
    assert "replay mapping: " not in text  # no plain decile lines on a terminal


def test_format_table_aligns_columns_without_colour_codes():
    text = format_table(
        ["topic", "msgs", "rate"],
        [["/scan", 1381, "10.00 Hz"], ["/livox/lidar", 1380, "9.99 Hz"], ["/tf_static", 1, "0.00 Hz"]],
        title="topics [recorded]",
        align=["left", "right", "right"],
    )
    assert "\x1b[" not in text
    lines = text.splitlines()
    assert lines[0] == "topics [recorded]"
    head = next(line for line in lines if "topic" in line and "msgs" in line)
    rows = [line for line in lines if line.lstrip().startswith("/")]
    assert [r.split()[0] for r in rows] == ["/scan", "/livox/lidar", "/tf_static"]
    # right-aligned numbers end in the header's column
    end = head.index("msgs") + len("msgs")
    assert [r[:end].split()[-1] for r in rows] == ["1381", "1380", "1"]
    assert all(line == line.rstrip() for line in lines)


def test_format_table_refuses_rows_of_the_wrong_width():
    with pytest.raises(ValueError, match="2 cells for 3 columns"):
        format_table(["a", "b", "c"], [[1, 2]])
    with pytest.raises(ValueError, match="align has 1 entries"):
        format_table(["a", "b"], [[1, 2]], align=["left"])
