"""Adaptive Monte Carlo localisation as Nav2's ``nav2_amcl`` computes it: its parameters and its particle filter.

``AmclParams`` declares the ``amcl:`` block of a Nav2 parameter file (Nav2's names and defaults);
``read_amcl`` reads and checks it. ``ParticleFilter`` holds the particles (x, y, yaw in the map
frame, metres and radians) and runs Nav2's steps on them:

1. ``init_gaussian(mean, cov)``: ``max_particles`` particles drawn around a pose (``/initialpose``);
2. ``motion_update(old, new)``: odometry's motion between two odometry poses, sampled per particle
   with Nav2's ``sample_motion_model_odometry``: the differential model (rotate, translate, rotate;
   noise from alpha1..alpha4) or the omni model (translate, strafe, rotate; alpha5 for the strafe);
3. ``sensor_update(scan)``: the likelihood-field model: every ``step``-th beam (step
   ``(n - 1) // (max_beams - 1)``), readings at or beyond the range limit or NaN skipped, the beam's
   end point looked up in the distance field of the map's occupied cells (``distance_transform_edt``,
   to the cells' edges, bilinear between cell centres, clipped at ``laser_likelihood_max_dist``;
   off the map counts as that maximum), and
   ``pz = z_hit * exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max``; a particle's weight is multiplied
   by ``1 + sum(pz^3)``. The weights' mean feeds the recovery averages ``w_slow`` / ``w_fast``
   (``recovery_alpha_slow`` / ``recovery_alpha_fast``);
4. ``resample()``: KLD-adaptive resampling: each new particle is, with probability
   ``max(0, 1 - w_fast / w_slow)``, a uniform pose in the map's free space, else drawn from the
   weights' CDF; particles fall into histogram bins (0.5 m, 0.5 m, 10 deg) and drawing stops once the
   count exceeds the KLD bound for the bins occupied (``kld_limit``: ``pf_err``, ``pf_z``, clamped to
   ``[min_particles, max_particles]``);
5. ``estimate()``: particles grouped into clusters of adjacent occupied bins; the heaviest cluster's
   weighted mean (yaw as the circular mean) is the pose, the whole set's covariance its covariance.

Map cells follow Nav2's AMCL map conversion: 0 free, 100 occupied, anything else unknown; world
-> cell truncates towards the lower cell (``navlog.replay.occupancy_map``). All randomness comes from
the ``numpy.random.Generator`` the filter is given, so a seed fixes every particle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from navlog.replay.geometry import angle_diff
from navlog.replay.limits import MAX_PARTICLES, MAX_TRANSFORM_TOLERANCE_S
from navlog.replay.nav2.schema import ERROR, SectionReader, param
from navlog.replay.occupancy_map import OccupancyMap

__all__ = [
    "DIFFERENTIAL",
    "OMNI",
    "AmclParams",
    "LikelihoodField",
    "ParticleFilter",
    "PoseEstimate",
    "kld_limit",
    "read_amcl",
    "sample_differential",
    "sample_omni",
]

DIFFERENTIAL = "nav2_amcl::DifferentialMotionModel"
OMNI = "nav2_amcl::OmniMotionModel"
# the histogram bins KLD sampling and clustering count: x, y (m), yaw (rad), as Nav2's kd-tree
BIN_SIZE = (0.5, 0.5, math.radians(10.0))


@dataclass(frozen=True)
class AmclParams:
    """``amcl`` node parameters (Nav2 names and defaults)."""

    alpha1: float = param(0.2, ge=0.0)  # rotation noise from rotation
    alpha2: float = param(0.2, ge=0.0)  # rotation noise from translation
    alpha3: float = param(0.2, ge=0.0)  # translation noise from translation
    alpha4: float = param(0.2, ge=0.0)  # translation noise from rotation
    alpha5: float = param(0.2, ge=0.0)  # strafe noise from translation (omni model)
    base_frame_id: str = "base_footprint"
    global_frame_id: str = "map"
    odom_frame_id: str = "odom"
    laser_likelihood_max_dist: float = param(2.0, gt=0.0)
    laser_max_range: float = 100.0  # <= 0: the scan's range_max
    laser_min_range: float = -1.0  # <= 0: the scan's range_min
    laser_model_type: str = param("likelihood_field", choices=("likelihood_field", "beam", "likelihood_field_prob"))
    max_beams: int = param(60, ge=2)
    max_particles: int = param(2000, ge=1, le=MAX_PARTICLES)
    min_particles: int = param(500, ge=1, le=MAX_PARTICLES)
    pf_err: float = param(0.05, gt=0.0)
    pf_z: float = param(0.99, gt=0.0)
    recovery_alpha_fast: float = param(0.0, ge=0.0, le=1.0)
    recovery_alpha_slow: float = param(0.0, ge=0.0, le=1.0)
    resample_interval: int = param(1, ge=1)
    robot_model_type: str = param(DIFFERENTIAL, choices=(DIFFERENTIAL, OMNI))
    sigma_hit: float = param(0.2, gt=0.0)
    tf_broadcast: bool = True
    transform_tolerance: float = param(1.0, ge=0.0, le=MAX_TRANSFORM_TOLERANCE_S)
    update_min_a: float = param(0.2, ge=0.0)
    update_min_d: float = param(0.25, ge=0.0)
    z_hit: float = param(0.5, ge=0.0)
    z_rand: float = param(0.5, ge=0.0)
    z_max: float = 0.05
    z_short: float = 0.05
    lambda_short: float = 0.1
    scan_topic: str = "scan"
    map_topic: str = "map"
    set_initial_pose: bool = False
    always_reset_initial_pose: bool = False
    initial_pose_x: float = 0.0  # from the ``initial_pose: {x, y, z, yaw}`` sub-mapping
    initial_pose_y: float = 0.0
    initial_pose_yaw: float = 0.0
    save_pose_rate: float = 0.5
    first_map_only: bool = False
    do_beamskip: bool = False
    beam_skip_distance: float = 0.5
    beam_skip_error_threshold: float = 0.9
    beam_skip_threshold: float = 0.3
    use_sim_time: bool = False
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "z_max",
        "z_short",
        "lambda_short",
        "save_pose_rate",
        "first_map_only",
        "do_beamskip",
        "beam_skip_distance",
        "beam_skip_error_threshold",
        "beam_skip_threshold",
        "use_sim_time",
        "introspection_mode",
        "bond_heartbeat_period",
        "map_subscribe_transient_local",
        "global_localization",
        "random_seed",  # Nav2 after Jazzy (navlog's filter draws from the run's seed)
    )


def read_amcl(r: SectionReader, params: dict, path: tuple) -> AmclParams:
    """The ``amcl`` block's parameters (``initial_pose: {x, y, z, yaw}`` included), checked as Nav2 does."""
    pose = params.get("initial_pose") if isinstance(params, dict) else None
    extra: dict[str, float] = {}
    if isinstance(pose, dict):
        for key, value in pose.items():
            if key not in ("x", "y", "z", "yaw"):
                r.unknown_key(str(key), path + ("initial_pose", key), ["x", "y", "z", "yaw"])
            elif isinstance(value, bool) or not isinstance(value, (int, float)):
                r.add(ERROR, path + ("initial_pose", key), f"expected a number, got {value!r} (0.0 used)")
            elif key != "z":
                extra[f"initial_pose_{key}"] = float(value)
    elif pose is not None:
        r.add(ERROR, path + ("initial_pose",), f"expected a mapping {{x, y, z, yaw}}, got {pose!r}")
    p = r.read(AmclParams, params, path, sections=("initial_pose",), extra=extra)
    if p.laser_model_type == "beam":
        r.add(
            ERROR,
            path + ("laser_model_type",),
            "'beam' is not implemented by navlog; use likelihood_field or likelihood_field_prob",
        )
    if p.min_particles > p.max_particles:
        r.add(
            ERROR,
            path + ("min_particles",),
            f"min_particles ({p.min_particles}) is above max_particles ({p.max_particles})",
        )
    return p


# ------------------------------------------------------------------ motion models


def sample_differential(
    poses: np.ndarray, old: np.ndarray, new: np.ndarray, alphas: tuple[float, ...], rng: np.random.Generator
) -> np.ndarray:
    """The particles moved by odometry from ``old`` to ``new`` (x, y, yaw), Nav2's differential model."""
    a1, a2, a3, a4 = alphas[:4]
    dx, dy = new[0] - old[0], new[1] - old[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < 0.01 else angle_diff(math.atan2(dy, dx), old[2])
    rot2 = angle_diff(angle_diff(new[2], old[2]), rot1)
    # rotation noise counts turning back as turning forward (a reversing robot is not rotating)
    rot1_noise = min(abs(angle_diff(rot1, 0.0)), abs(angle_diff(rot1, math.pi)))
    rot2_noise = min(abs(angle_diff(rot2, 0.0)), abs(angle_diff(rot2, math.pi)))
    n = len(poses)
    rot1_hat = rot1 - rng.normal(0.0, math.sqrt(a1 * rot1_noise**2 + a2 * trans**2), n)
    trans_hat = trans - rng.normal(0.0, math.sqrt(a3 * trans**2 + a4 * rot1_noise**2 + a4 * rot2_noise**2), n)
    rot2_hat = rot2 - rng.normal(0.0, math.sqrt(a1 * rot2_noise**2 + a2 * trans**2), n)
    out = poses.copy()
    heading = poses[:, 2] + rot1_hat
    out[:, 0] += trans_hat * np.cos(heading)
    out[:, 1] += trans_hat * np.sin(heading)
    out[:, 2] = poses[:, 2] + rot1_hat + rot2_hat  # not wrapped (``ParticleFilter``)
    return out


def sample_omni(
    poses: np.ndarray, old: np.ndarray, new: np.ndarray, alphas: tuple[float, ...], rng: np.random.Generator
) -> np.ndarray:
    """The particles moved by odometry from ``old`` to ``new`` (x, y, yaw), Nav2's omni model."""
    a1, a2, a3, a4, a5 = alphas[:5]
    dx, dy = new[0] - old[0], new[1] - old[1]
    trans = math.hypot(dx, dy)
    rot = angle_diff(new[2], old[2])
    n = len(poses)
    bearing = angle_diff(math.atan2(dy, dx), old[2]) + poses[:, 2]
    trans_hat = trans + rng.normal(0.0, math.sqrt(a3 * trans**2 + a1 * rot**2), n)
    rot_hat = rot + rng.normal(0.0, math.sqrt(a4 * trans**2 + a2 * rot**2), n)
    strafe_hat = rng.normal(0.0, math.sqrt(a1 * rot**2 + a5 * trans**2), n)
    cs, sn = np.cos(bearing), np.sin(bearing)
    out = poses.copy()
    out[:, 0] += trans_hat * cs + strafe_hat * sn
    out[:, 1] += trans_hat * sn - strafe_hat * cs
    out[:, 2] = poses[:, 2] + rot_hat  # not wrapped (``ParticleFilter``)
    return out


MOTION_MODELS = {DIFFERENTIAL: sample_differential, OMNI: sample_omni}


# ------------------------------------------------------------------ sensor model


class LikelihoodField:
    """The distance (m) from any point to the nearest occupied cell's edge, clipped at ``max_dist``.

    ``distance_transform_edt`` gives each cell centre's distance to the nearest occupied cell centre;
    half a cell less is the distance to that cell's edge. Inside occupied cells the distance to the
    nearest free cell's edge counts negative; ``lookup`` interpolates this signed field bilinearly
    between cell centres and reads negatives as 0, so a beam ending on a wall's surface reads 0
    wherever the surface lies within its cell. (nav2_amcl reads the value of the cell a point falls
    in, which places surfaces up to a cell deep into the walls and biases the pose by centimetres.)
    """

    def __init__(self, occ_map: OccupancyMap, max_dist: float) -> None:
        self.map = occ_map
        data = np.asarray(occ_map.data)
        occupied = data == 100
        self.max_dist = float(max_dist)
        if occupied.any():
            from scipy import ndimage

            # signed, in cells: + outside (to the nearest occupied cell's edge), - inside occupied cells
            outside = np.asarray(ndimage.distance_transform_edt(~occupied), dtype=np.float64) - 0.5
            inside = np.asarray(ndimage.distance_transform_edt(occupied), dtype=np.float64) - 0.5
            signed = np.where(occupied, -inside, outside) * occ_map.resolution
            self.distance = np.minimum(signed, self.max_dist)
        else:
            self.distance = np.full(data.shape, self.max_dist)
        self.free_cells = np.flatnonzero(data.ravel() == 0)  # row-major (row = y) indices

    def lookup(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Distances at world points, bilinear between cell centres; beyond the map ``max_dist``."""
        from scipy import ndimage

        m = self.map
        col = (np.asarray(x, dtype=np.float64) - m.origin[0]) / m.resolution - 0.5
        row = (np.asarray(y, dtype=np.float64) - m.origin[1]) / m.resolution - 0.5
        coords = np.stack([row.ravel(), col.ravel()])
        out = np.maximum(np.asarray(ndimage.map_coordinates(self.distance, coords, order=1, mode="nearest")), 0.0)
        off = (coords[0] < -0.5) | (coords[0] >= m.height - 0.5) | (coords[1] < -0.5) | (coords[1] >= m.width - 0.5)
        out[off] = self.max_dist
        return out.reshape(np.shape(x))

    def random_free_poses(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` poses uniform over the free cells' centres, uniform yaw (AMCL's recovery particles)."""
        if not len(self.free_cells):
            raise ValueError("the map has no free cell to place particles in")
        idx = self.free_cells[rng.integers(0, len(self.free_cells), n)]
        row, col = np.divmod(idx, self.map.width)
        m = self.map
        x = m.origin[0] + (col + 0.5) * m.resolution
        y = m.origin[1] + (row + 0.5) * m.resolution
        return np.column_stack([x, y, rng.uniform(-np.pi, np.pi, n)])


@dataclass(frozen=True)
class Scan:
    """One scan's beams as the sensor model reads them: ranges (m), bearings in the laser frame (rad)."""

    ranges: np.ndarray
    bearings: np.ndarray
    range_min: float
    range_max: float


def kld_limit(k: np.ndarray | int, pf_err: float, pf_z: float, min_n: int, max_n: int) -> np.ndarray:
    """Particles needed for ``k`` occupied bins (Fox's KLD bound, as Nav2's ``pf_resample_limit``)."""
    k = np.asarray(k, dtype=np.float64)
    km1 = np.maximum(k - 1.0, 1e-12)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * pf_z
    n = np.ceil(km1 / (2.0 * pf_err) * x**3)
    return np.where(k <= 1, max_n, np.clip(n, min_n, max_n)).astype(np.int64)


def _bin_keys(poses: np.ndarray) -> np.ndarray:
    return np.floor(poses / np.asarray(BIN_SIZE)).astype(np.int64)


def _closed_up(keys: np.ndarray) -> np.ndarray:
    """Bin indices along one axis from 0, each gap of two or more empty bins closed to one: bins stay
    neighbours exactly when they were, and the axis spans at most twice its occupied bins (the yaw is never
    wrapped, so after many turns its bins would span thousands)."""
    values, index = np.unique(keys, return_inverse=True)
    steps = np.minimum(np.diff(values), 2)
    return np.concatenate([[0], np.cumsum(steps)])[index.reshape(-1)]


@dataclass(frozen=True)
class PoseEstimate:
    """The filter's pose (x, y, yaw), its 3x3 covariance, the heaviest cluster's weight and cluster count."""

    pose: np.ndarray
    covariance: np.ndarray
    weight: float
    clusters: int


class ParticleFilter:
    """Nav2 AMCL's particle filter over a likelihood field (see the module docstring).

    The particles' yaw is continuous, never wrapped to [-pi, pi), as nav2_amcl's motion models add to it:
    the clusters are found in bins of the yaw as it is, and a set heading near +-180 degrees wrapped into
    bins at both ends of the range would split in two, its estimate the mean of one half (10-15 degrees
    off in the sandbox, where the robot drives west)."""

    def __init__(self, params: AmclParams, field: LikelihoodField, rng: np.random.Generator) -> None:
        self.p = params
        self.field = field
        self.rng = rng
        self.poses = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.w_slow = 0.0
        self.w_fast = 0.0
        self._motion = MOTION_MODELS[params.robot_model_type]
        self._alphas = (params.alpha1, params.alpha2, params.alpha3, params.alpha4, params.alpha5)

    def init_gaussian(self, mean, cov) -> None:
        """``max_particles`` particles drawn from N(mean, cov) (x, y, yaw; cov 3x3), equal weights."""
        mean = np.asarray(mean, dtype=np.float64)
        cov = np.asarray(cov, dtype=np.float64)
        n = self.p.max_particles
        self.poses = self.rng.multivariate_normal(mean, cov, size=n, method="eigh")
        self.weights = np.full(n, 1.0 / n)
        self.w_slow = self.w_fast = 0.0

    def motion_update(self, old, new) -> None:
        """Move every particle by the odometry motion from pose ``old`` to ``new`` (x, y, yaw)."""
        self.poses = self._motion(self.poses, np.asarray(old, float), np.asarray(new, float), self._alphas, self.rng)

    def beam_indices(self, n_ranges: int) -> np.ndarray:
        """The beams the sensor model reads: every ``(n - 1) // (max_beams - 1)``-th (at least every one)."""
        step = max(1, (n_ranges - 1) // (self.p.max_beams - 1))
        return np.arange(0, n_ranges, step)

    def sensor_update(self, scan: Scan, laser_in_base) -> float:
        """Weight the particles by the likelihood field; returns the weights' sum before normalising."""
        p = self.p
        # as nav2_amcl: the parameters narrow the scan's own limits, never widen them (a 20 m laser under
        # Nav2's default laser_max_range of 100 m keeps 20 m: beams at it are no-returns, z_rand is per 20 m)
        range_max = min(scan.range_max, p.laser_max_range) if p.laser_max_range > 0 else scan.range_max
        range_min = max(scan.range_min, p.laser_min_range) if p.laser_min_range > 0 else scan.range_min
        idx = self.beam_indices(len(scan.ranges))
        ranges = np.asarray(scan.ranges, dtype=np.float64)[idx]
        bearings = np.asarray(scan.bearings, dtype=np.float64)[idx]
        # readings at or below range_min count as max range; max range and NaN are skipped
        ranges = np.where(ranges <= range_min, range_max, ranges)
        use = ~np.isnan(ranges) & (ranges < range_max)
        ranges, bearings = ranges[use], bearings[use]
        lx, ly, lyaw = laser_in_base
        c, s = np.cos(self.poses[:, 2]), np.sin(self.poses[:, 2])
        ox = self.poses[:, 0] + c * lx - s * ly
        oy = self.poses[:, 1] + s * lx + c * ly
        ang = self.poses[:, 2:3] + lyaw + bearings[None, :]
        d = self.field.lookup(ox[:, None] + ranges * np.cos(ang), oy[:, None] + ranges * np.sin(ang))
        pz = p.z_hit * np.exp(-(d * d) / (2.0 * p.sigma_hit**2)) + p.z_rand / range_max
        if p.laser_model_type == "likelihood_field_prob":
            # the product of the beams' pz, kept in logarithms so that many beams do not underflow
            with np.errstate(divide="ignore"):
                log_w = np.log(self.weights) + np.sum(np.log(pz), axis=1)
            top = float(np.max(log_w))
            if not math.isfinite(top):
                self.weights = np.full(len(self.weights), 1.0 / len(self.weights))
                return 0.0
            scaled = np.exp(log_w - top)
            total = float(scaled.sum()) * math.exp(top)
            self._reweighted(scaled / scaled.sum(), total)
            return total
        self.weights = self.weights * (1.0 + np.sum(pz**3, axis=1))
        total = float(self.weights.sum())
        if total > 0.0:
            self._reweighted(self.weights / total, total)
        else:
            self.weights = np.full(len(self.weights), 1.0 / len(self.weights))
        return total

    def _reweighted(self, weights: np.ndarray, total: float) -> None:
        """Keep the normalised weights; feed the weights' mean to the recovery averages (when it is > 0)."""
        p = self.p
        self.weights = weights
        w_avg = total / len(weights)
        if w_avg > 0.0:
            self.w_slow = w_avg if self.w_slow == 0.0 else self.w_slow + p.recovery_alpha_slow * (w_avg - self.w_slow)
            self.w_fast = w_avg if self.w_fast == 0.0 else self.w_fast + p.recovery_alpha_fast * (w_avg - self.w_fast)

    def resample(self) -> int:
        """KLD-adaptive resampling with random recovery particles; returns the new particle count."""
        p, rng = self.p, self.rng
        w_diff = max(0.0, 1.0 - self.w_fast / self.w_slow) if self.w_slow > 0.0 else 0.0
        n_max = p.max_particles
        cdf = np.cumsum(self.weights)
        cdf /= cdf[-1]
        random = rng.random(n_max) < w_diff
        drawn = np.minimum(np.searchsorted(cdf, rng.random(n_max), side="right"), len(cdf) - 1)
        new = self.poses[drawn]
        if random.any():
            new[random] = self.field.random_free_poses(int(random.sum()), rng)
        # stop at the first count above the KLD bound for the bins occupied so far
        keys = _bin_keys(new)
        _, first = np.unique(keys, axis=0, return_index=True)
        is_new = np.zeros(n_max, dtype=bool)
        is_new[first] = True
        counts = np.arange(1, n_max + 1)
        over = np.flatnonzero(counts > kld_limit(np.cumsum(is_new), p.pf_err, p.pf_z, p.min_particles, n_max))
        n = int(counts[over[0]]) if len(over) else n_max
        self.poses = new[:n]
        self.weights = np.full(n, 1.0 / n)
        if w_diff > 0.0:
            self.w_slow = self.w_fast = 0.0
        return n

    def estimate(self) -> PoseEstimate:
        """The heaviest cluster's mean pose and the whole set's covariance (Nav2's published estimate)."""
        from scipy import ndimage

        rel = np.column_stack([_closed_up(column) for column in _bin_keys(self.poses).T])
        grid = np.zeros(tuple(rel.max(axis=0) + 1), dtype=bool)
        grid[rel[:, 0], rel[:, 1], rel[:, 2]] = True
        labels, count = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
        particle_label = labels[rel[:, 0], rel[:, 1], rel[:, 2]]
        cluster_w = np.bincount(particle_label, weights=self.weights, minlength=count + 1)
        best = int(np.argmax(cluster_w[1:])) + 1
        mean = self._mean(self.poses[particle_label == best], self.weights[particle_label == best])
        return PoseEstimate(mean, self.covariance(), float(cluster_w[best]), int(count))

    @staticmethod
    def _mean(poses: np.ndarray, w: np.ndarray) -> np.ndarray:
        total = w.sum()
        yaw = math.atan2(float(w @ np.sin(poses[:, 2])), float(w @ np.cos(poses[:, 2])))
        return np.array([float(w @ poses[:, 0]) / total, float(w @ poses[:, 1]) / total, yaw])

    def covariance(self) -> np.ndarray:
        """The weighted covariance of x, y and the circular spread of yaw (``-2 ln R``), 3x3."""
        w = self.weights / self.weights.sum()
        xy = self.poses[:, :2]
        mean = w @ xy
        d = xy - mean
        cov = np.zeros((3, 3))
        cov[:2, :2] = (d * w[:, None]).T @ d
        r = math.hypot(float(w @ np.cos(self.poses[:, 2])), float(w @ np.sin(self.poses[:, 2])))
        cov[2, 2] = -2.0 * math.log(max(r, 1e-300))
        return cov
