"""TUM trajectory files (``t x y z qx qy qz qw``, t in seconds), the format evo and KISS-ICP read.

The one TUM module of navlog: it reads and writes plain arrays (``TumPoses``: times in integer
nanoseconds, positions (N, 3), quaternions (N, 4) x, y, z, w); ``navlog.analysis`` builds its
``Trajectory`` from them.

Lines that are blank or start with ``#`` are skipped. Times are read exactly (decimal text to
integer nanoseconds, no float rounding) and written with 9 decimals from the integer, so a file
written by ``write_tum`` reads back to the same nanoseconds and rewrites to the same bytes.
Positions and quaternions are written with 9 decimals (``-0.000000000`` as ``0.000000000``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from decimal import ROUND_HALF_EVEN, Decimal, InvalidOperation
from pathlib import Path
from typing import NamedTuple

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.geometry import matrices_to_canonical_quats, quat_norm
from navlog.replay.io.atomic import write_file

__all__ = [
    "HEADER",
    "TumPoses",
    "format_number",
    "format_rows",
    "format_seconds",
    "parse_seconds_ns",
    "parse_tum",
    "read_tum",
    "write_poses",
    "write_tum",
]

HEADER = "# t x y z qx qy qz qw\n"


class TumPoses(NamedTuple):
    """The poses of a TUM file: ``times_ns`` (N,) int64, ``positions`` (N, 3), ``quaternions`` (N, 4) x y z w."""

    times_ns: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray


# ---------------------------------------------------------------- writing


def format_seconds(ns: int) -> str:
    """Seconds with exactly 9 decimals from integer nanoseconds."""
    ns = int(ns)
    sign = "-" if ns < 0 else ""
    sec, nsec = divmod(abs(ns), 1_000_000_000)
    return f"{sign}{sec}.{nsec:09d}"


def format_number(v: float) -> str:
    text = f"{float(v):.9f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def format_rows(times_ns: Iterable[int], positions: np.ndarray, quaternions: np.ndarray, *, header: bool = True) -> str:
    """TUM text from times (ns), positions (N, 3) and quaternions (N, 4, x y z w)."""
    out = [HEADER] if header else []
    for t, p, q in zip(times_ns, positions, quaternions):
        out.append(f"{format_seconds(int(t))} {' '.join(format_number(v) for v in (*p, *q))}\n")
    return "".join(out)


def write_tum(
    path: str | Path, times_ns: Iterable[int], positions: np.ndarray, quaternions: np.ndarray, *, header: bool = True
) -> Path:
    """Write a TUM file (parent folders created)."""
    return write_file(Path(path), format_rows(times_ns, positions, quaternions, header=header))


def write_poses(path: str | Path, times_ns: Iterable[int], poses: Iterable[np.ndarray]) -> Path:
    """Write 4x4 poses as a TUM file (quaternions as SciPy's ``Rotation.from_matrix(...).as_quat(canonical=True)``)."""
    mats = np.asarray(list(poses), dtype=np.float64).reshape(-1, 4, 4)
    return write_tum(path, list(times_ns), mats[:, :3, 3], matrices_to_canonical_quats(mats[:, :3, :3]))


# ---------------------------------------------------------------- reading


def parse_seconds_ns(text: str) -> int:
    """Integer nanoseconds from a decimal number of seconds (``"12.000000001"`` -> 12000000001)."""
    value = Decimal(text)
    if not value.is_finite():
        raise ValueError(f"time {text!r} is not finite")
    return int((value * 1_000_000_000).to_integral_value(rounding=ROUND_HALF_EVEN))


def parse_tum(text: str, source: str = "<text>") -> TumPoses:
    """The poses of TUM text, times strictly increasing; errors name ``source`` and the line."""
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
        if not 0.0 < quat_norm(*row[3:]) < math.inf:
            raise NavlogError(f"{source}:{lineno}: quaternion (qx qy qz qw) is zero or too long to normalise")
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
    return TumPoses(np.asarray(times, dtype=np.int64), arr[:, :3], arr[:, 3:])


def read_tum(path: str | Path) -> TumPoses:
    """Read a TUM trajectory file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise NavlogError(f"{p}: no such trajectory file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise NavlogError(f"{p}: cannot read trajectory: {exc}") from None
    return parse_tum(text, str(p))


def _is_float(v: str) -> bool:
    try:
        float(v)
        return True
    except ValueError:
        return False


def _clip(line: str, n: int = 80) -> str:
    return line if len(line) <= n else line[: n - 3] + "..."
