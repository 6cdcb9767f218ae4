"""A small progress bar on stderr for long work (recording, replay, conversion).

It reads the wall clock only to throttle drawing; nothing it does reaches node logic or log content.
On a terminal it redraws one line; elsewhere (CI logs) it prints a line every 10 %.
"""

from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, total: float, label: str, unit: str = "s", enabled: bool = True) -> None:
        self.total = max(float(total), 1e-9)
        self.label = label
        self.unit = unit
        self.enabled = enabled
        self.tty = sys.stderr.isatty()
        self._last_draw = 0.0
        self._last_decile = -1
        self.start = time.perf_counter()

    def update(self, done: float) -> None:
        if not self.enabled:
            return
        frac = min(1.0, max(0.0, done / self.total))
        if self.tty:
            now = time.perf_counter()
            if now - self._last_draw < 0.2 and frac < 1.0:
                return
            self._last_draw = now
            bar = "#" * int(frac * 30)
            sys.stderr.write(f"\r{self.label} [{bar:<30}] {frac * 100:5.1f}% {done:8.1f}/{self.total:.1f} {self.unit}")
            sys.stderr.flush()
        else:
            decile = int(frac * 10)
            if decile > self._last_decile:
                self._last_decile = decile
                sys.stderr.write(f"{self.label}: {decile * 10}%\n")

    def close(self) -> None:
        if self.enabled and self.tty:
            sys.stderr.write("\n")
            sys.stderr.flush()
