"""TUM trajectory files: one pose per line, ``t x y z qx qy qz qw``, t in seconds.

Lines that are blank or start with ``#`` are skipped. Times are read exactly (decimal text to
integer nanoseconds, no float rounding) and written with 9 decimals from the integer, so a file
written by ``write_tum`` reads back to the same nanoseconds and rewrites to the same bytes.
"""

from __future__ import annotations

from decimal import ROUND_HALF_EVEN, Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from navlog.analysis.metrics.trajectory import Trajectory
from navlog.errors import NavlogError
from navlog.replay.io.tum import HEADER, format_rows, format_seconds  # noqa: F401  (one writer for both packages)


def parse_seconds_ns(text: str) -> int:
    """Integer nanoseconds from a decimal number of seconds (``"12.000000001"`` -> 12000000001)."""
    value = Decimal(text)
    if not value.is_finite():
        raise ValueError(f"time {text!r} is not finite")
    return int((value * 1_000_000_000).to_integral_value(rounding=ROUND_HALF_EVEN))


def parse_tum(text: str, source: str = "<text>") -> Trajectory:
    """A Trajectory from TUM text; errors name ``source`` and the line."""
    times: list[int] = []
    values: list[list[float]] = []
    lines: list[int] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = line.split()
        if len(fields) != 8:
            raise NavlogError(
                f"{source}:{lineno}: expected 8 numbers 't x y z qx qy qz qw', got {len(fields)}: {_clip(line)}"
            )
        try:
            t = parse_seconds_ns(fields[0])
        except (InvalidOperation, ValueError):
            raise NavlogError(f"{source}:{lineno}: time {fields[0]!r} is not a number of seconds") from None
        try:
            row = [float(v) for v in fields[1:]]
        except ValueError:
            bad = next(v for v in fields[1:] if not _is_float(v))
            raise NavlogError(f"{source}:{lineno}: {bad!r} is not a number") from None
        if not all(np.isfinite(row)):
            raise NavlogError(f"{source}:{lineno}: pose values must be finite: {_clip(line)}")
        if np.linalg.norm(row[3:]) < 1e-9:
            raise NavlogError(f"{source}:{lineno}: quaternion (qx qy qz qw) is zero")
        if times and t <= times[-1]:
            raise NavlogError(
                f"{source}:{lineno}: time {fields[0]} s does not increase "
                f"(line {lines[-1]} has {format_seconds(times[-1])} s); TUM files must be sorted by time"
            )
        times.append(t)
        values.append(row)
        lines.append(lineno)
    if not times:
        raise NavlogError(f"{source}: no poses (expected lines 't x y z qx qy qz qw')")
    arr = np.asarray(values, dtype=np.float64)
    return Trajectory(np.asarray(times, dtype=np.int64), arr[:, :3], arr[:, 3:])


def read_tum(path: str | Path) -> Trajectory:
    """Read a TUM trajectory file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise NavlogError(f"{p}: no such trajectory file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise NavlogError(f"{p}: cannot read trajectory: {exc}") from None
    return parse_tum(text, str(p))


def format_tum(traj: Trajectory, *, header: bool = True) -> str:
    """TUM text: time with 9 decimals, position and quaternion with 9 decimals."""
    return format_rows(traj.times_ns, traj.positions, traj.quaternions, header=header)


def write_tum(path: str | Path, traj: Trajectory, *, header: bool = True) -> Path:
    """Write a TUM file (parent folders created)."""
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(format_tum(traj, header=header), encoding="utf-8")
    except OSError as exc:
        raise NavlogError(f"{p}: cannot write trajectory: {exc.strerror}") from None
    return p


def _is_float(v: str) -> bool:
    try:
        float(v)
        return True
    except ValueError:
        return False


def _clip(line: str, n: int = 80) -> str:
    return line if len(line) <= n else line[: n - 3] + "..."
