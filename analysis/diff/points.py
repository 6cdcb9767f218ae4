"""Point maps (PCD) compared: Chamfer and Hausdorff distances, and the share of points beyond tau.

Distances are nearest-neighbour distances both ways (``navlog.analysis.metrics.maps``:
``nearest_distances`` and ``chamfer_hausdorff``); a point is beyond tau when its nearest neighbour
in the other cloud is farther than ``tau_m``; the share is over the points of both clouds.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import PointsTolerance, as_dict, within
from navlog.analysis.metrics.maps import chamfer_hausdorff, nearest_distances

__all__ = ["compare_points"]


def compare_points(name: str, a: np.ndarray, b: np.ndarray, tol: PointsTolerance) -> Check:
    """EQUAL for identical arrays; WITHIN when the Chamfer distance and the share beyond tau are within
    ``tol``; else CHANGED (also when one cloud is empty and the other is not)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
    ch = chamfer_hausdorff(a, b)
    beyond = int(np.count_nonzero(nearest_distances(a, b) > tol.tau_m)) + int(
        np.count_nonzero(nearest_distances(b, a) > tol.tau_m)
    )
    total = len(a) + len(b)
    share = beyond / total if total else 0.0
    values: dict[str, Any] = {
        "points_a": len(a),
        "points_b": len(b),
        "chamfer_m": ch["chamfer_m"],
        "hausdorff_m": ch["hausdorff_m"],
        "beyond_tau": beyond,
        "beyond_share": share,
    }
    if a.shape == b.shape and np.array_equal(a, b):
        verdict = Verdict.EQUAL
    elif (chamfer := ch["chamfer_m"]) is None:
        verdict = Verdict.CHANGED
    else:
        ok = within(chamfer, tol.chamfer_m) and within(share, tol.beyond_share)
        verdict = Verdict.WITHIN if ok else Verdict.CHANGED
    detail = f"{len(a)} -> {len(b)} points, {beyond} beyond {tol.tau_m:g} m"
    return Check(name, "points", verdict, values, as_dict(tol), detail)
