"""A NumPy formulation of the occupancy grid's ray update: a reference oracle for the compiled kernel.

``numpy_scan_update`` has the signature of ``occupancy_kernels.scan_update`` and computes the same
bits with (beams x samples) arrays: the beams taken in ``groups`` groups of similar length (sorted by
their number of free samples), each group's arrays as long as its longest beam. The grid takes the
compiled kernel only; the tests hold this one to check it against.
"""

from __future__ import annotations

import numpy as np


def crossed(t: np.ndarray, last: np.ndarray, d2c: np.ndarray, g0: np.ndarray, nx: int, ncell: int) -> np.ndarray:
    """(beams x samples) flat cells of the beams' samples at ``t``; ``ncell`` (a spare cell) for samples
    past a beam's free part."""
    x = g0[0] + d2c[:, 0:1] * t[None, :]  # float32, as the kernel rounds
    gx = x.astype(np.intp)  # non-negative inside the beam: truncation = floor
    y = g0[1] + d2c[:, 1:2] * t[None, :]
    cell = y.astype(np.intp) * nx + gx
    past = t[None, :] > last[:, None]
    past[:, 0] = False  # the sensor's own cell is always crossed
    cell[past] = ncell
    return cell


def numpy_scan_update(
    logodds: np.ndarray,
    seen: np.ndarray,
    mask: np.ndarray,
    nx: int,
    g0: np.ndarray,
    directions: np.ndarray,
    t: np.ndarray,
    last: np.ndarray,
    end_cells: np.ndarray,
    l_miss: np.float32,
    l_min: np.float32,
    l_hit: np.float32,
    l_max: np.float32,
    groups: int = 4,
) -> None:
    """``scan_update`` with NumPy arrays (``mask`` is left untouched: a work array of its own is used)."""
    ncell = len(logodds)
    work = np.zeros(ncell + 1, dtype=np.int8)
    samples = np.maximum(np.searchsorted(t, last, side="right"), 1)  # the sensor's own sample at least
    order = np.argsort(samples, kind="stable")
    bounds = np.linspace(0, len(order), groups + 1).astype(int)
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi > lo:
            beams = order[lo:hi]
            cells = crossed(t[: samples[beams[-1]]], last[beams], directions[beams], g0, nx, ncell)
            work[cells.reshape(-1)] = 1
    work[end_cells] = 2  # a beam's own end cell is not cleared by it (nor by grazing neighbours in this scan)
    work = work[:ncell]
    f = np.flatnonzero(work == 1)
    o = np.flatnonzero(work == 2)
    logodds[f] = np.maximum(logodds[f] + l_miss, l_min)
    logodds[o] = np.minimum(logodds[o] + l_hit, l_max)
    seen[f] = True
    seen[o] = True
