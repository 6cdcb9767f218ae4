"""navlog view --spawn on a machine without a display: refused at once, saying why and what to do."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from navlog.analysis.view.log_view import display_missing


def test_display_missing_reads_the_environment_of_linux_only():
    assert "neither DISPLAY nor WAYLAND_DISPLAY" in display_missing({}, "linux")
    assert display_missing({"DISPLAY": ":0"}, "linux") is None
    assert display_missing({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert display_missing({"DISPLAY": ""}, "freebsd14") is not None  # set but empty is no display
    assert display_missing({}, "darwin") is None and display_missing({}, "win32") is None


def test_spawn_without_a_display_fails_before_reading_the_log(sample_log):
    # it used to convert the whole log, start a viewer that could not open a window, and fail after
    # the 30 s flush timeout with "no Rerun viewer took the recording"
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "navlog", "view", str(sample_log), "--spawn"],
        env=env,
        capture_output=True,
        text=True,
        timeout=25,
    )
    assert time.perf_counter() - t0 < 25
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert line.count("\n") == 0
    assert "neither DISPLAY nor WAYLAND_DISPLAY is set" in line
    assert "--save FILE.rrd" in line and "--connect" in line
