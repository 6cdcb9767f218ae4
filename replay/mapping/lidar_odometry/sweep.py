"""A sweep's preparation: sensor → base_link, deskew, voxel filters.

Once the motion over a sweep is known from the IMU and odometry tracks (``LidarOdometry.plan``),
moving its points into base_link, deskewing them and voxel-filtering them (``prepare_sweep``) needs
nothing from earlier sweeps: a ``SweepJob`` holds all it takes, and a plan carries one to wherever it
is completed (``odometry_process``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from navlog.replay.mapping.lidar_odometry.deskew import move_by_slot
from navlog.replay.mapping.lidar_odometry.preprocess import reduced

__all__ = ["PreparedSweep", "SweepJob", "prepare_sweep"]


@dataclass(frozen=True)
class SweepJob:
    """What a sweep's preparation needs: its valid points, the sensor mount, the motion to deskew by."""

    points: np.ndarray  # (N, 3) float64 in the sensor frame, finite and within the range limits
    extrinsic: np.ndarray  # 4x4 base_link <- sensor
    times: np.ndarray | None  # (N,) seconds after the stamp, when deskewed
    deskew: np.ndarray | None  # (K, 4, 4) base_link at the reference time <- base_link at each slot's time
    save_voxel: float  # the maps' voxel filter
    scan_voxel: float  # the registration's voxel filter on the result (0: the registrar filters its own)
    keep_base: bool  # give back the whole deskewed sweep (a frame published as a cloud)


@dataclass(frozen=True)
class PreparedSweep:
    base: np.ndarray | None  # (N, 3) the deskewed sweep in base_link (when kept)
    fine: np.ndarray  # (M, 3) one point per ``save_voxel`` voxel
    scan: np.ndarray | None  # (S, 3) one point per ``scan_voxel`` voxel of ``fine`` (when asked for)


def prepare_sweep(job: SweepJob) -> PreparedSweep:
    """The sweep in base_link (deskewed when the job says so), then its voxel filters."""
    e = job.extrinsic
    base = job.points @ e[:3, :3].T + e[:3, 3]
    if job.deskew is not None and job.times is not None:
        base = move_by_slot(base, job.times, job.deskew)
    fine = reduced(base, job.save_voxel)
    scan = reduced(fine, job.scan_voxel) if job.scan_voxel > 0 else None
    return PreparedSweep(base if job.keep_base else None, fine, scan)
