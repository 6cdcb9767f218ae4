"""TUM trajectory text (``t x y z qx qy qz qw``), the format evo and KISS-ICP read.

Writing lives here so that replay outputs can be written without the analysis package; reading
and the trajectory type are in ``analysis.tum`` and ``analysis.trajectory``.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from navlog.errors import NavlogError

HEADER = "# t x y z qx qy qz qw\n"


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


def write_poses(path: str | Path, times_ns: Iterable[int], poses: Iterable[np.ndarray]) -> Path:
    """Write 4x4 poses as a TUM file."""
    from scipy.spatial.transform import Rotation

    mats = np.asarray(list(poses), dtype=np.float64).reshape(-1, 4, 4)
    quats = Rotation.from_matrix(mats[:, :3, :3]).as_quat(canonical=True) if len(mats) else np.zeros((0, 4))
    p = Path(path)
    try:
        p.write_text(format_rows(list(times_ns), mats[:, :3, 3], quats), encoding="utf-8")
    except OSError as exc:
        raise NavlogError(f"{p}: cannot write trajectory: {exc.strerror}") from None
    return p
