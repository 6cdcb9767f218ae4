"""NumPy forms of the MPPI kernels: slow, plainly vectorised, the oracles the compiled kernels must equal bit for bit."""

from __future__ import annotations

import numpy as np


def numpy_clamp_rollouts(cv, state, axes, ups, downs):
    """``optimizer.clamp_rollouts`` with NumPy, one time step at a time over the whole batch: the oracle.

    The bounds are taken in float64 from the float32 control before, the clamped control stored as
    float32, as the kernel does.
    """
    t = cv.shape[2]
    for a in axes:
        col = np.ascontiguousarray(cv[a].T)  # (T, B): one row per time step
        last = state[a, :, 0].copy()
        up, down = ups[a], downs[a]
        for j in range(1, t):
            last64 = last.astype(np.float64)
            if a == 2:  # wz: symmetric, whatever the sign
                lo, hi = last64 + down, last64 + up
            else:  # forward: accelerate by up, slow by down; reverse: mirrored
                fwd = last > 0
                lo = last64 + np.where(fwd, down, -up)
                hi = last64 + np.where(fwd, up, -down)
            np.clip(col[j - 1], lo, hi, out=col[j - 1])
            last = col[j - 1]
        cv[a] = col.T
        state[a, :, 1:] = cv[a, :, :-1]
