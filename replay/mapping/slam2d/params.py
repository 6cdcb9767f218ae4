"""Parameters of the 2D SLAM, under slam_toolbox's names where they mean the same.

Lengths in metres, angles in radians, times in seconds. Defaults are slam_toolbox's (Humble,
``mapper_params_online_async.yaml``) except where noted: the correlation grid is 0.025 m instead of
0.01 m (a quarter of the cells to search; the final least-squares refinement recovers the
sub-cell pose), and the edge noise and robust kernel, which slam_toolbox's Ceres back end does not
expose as parameters, are navlog's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from navlog.replay.config import param
from navlog.replay.limits import (
    MAX_GRID_CELLS,
    MAX_GRID_RESOLUTION_M,
    MAX_PERIOD_S,
    MIN_GRID_RESOLUTION_M,
    MIN_MAP_PERIOD_S,
)

# a square searched on the correlation grid spans at most this many of its cells per side (8 m at 0.025 m: 320;
# a lookup grid for 800 is ~0.3 GB of pooled levels)
MAX_SEARCH_CELLS = 800

# the yaws a search tries (2 coarse_search_angle_offset / coarse_angle_resolution + 1) at most: a tenth of a degree
# around the whole turn
MAX_SEARCH_YAWS = 3601
# a standard deviation of an edge or of the odometry: from a tenth of a millimetre (or milliradian) up
SIGMA_RANGE = (1e-4, 1e3)

# slam_toolbox's odometry frame; a replay takes the one a navlog recording names instead (the mapping
# pipeline's settle)
DEFAULT_ODOM_FRAME = "odom"


def finer_grid_cost(resolution: float) -> str | None:
    """What a correlation grid finer than navlog's default costs, said once for the check and the run (slam_toolbox's
    own default, 0.01 m, is one); None for the default or coarser."""
    default = SlamParams.correlation_search_space_resolution
    if not 0 < resolution < default:
        return None
    return (
        f"the SLAM's searches cover {(default / resolution) ** 2:.1f} times the cells of navlog's default {default} m, "
        "whose refinement finds the pose between cells"
    )


@dataclass(frozen=True)
class SlamParams:
    resolution: float = 0.05  # of the published occupancy grid
    # readings beyond it are not used for matching, and clear up to it in the map without marking (unless the
    # map's own OccupancyParams.max_laser_range, occupancy.grid.max_laser_range in the pipeline, is set)
    max_laser_range: float = 20.0
    minimum_travel_distance: float = 0.5  # a scan becomes a keyframe after this much travel ...
    minimum_travel_heading: float = 0.5  # ... or this much turning since the last keyframe
    scan_buffer_size: int = 10  # the running buffer: keyframes a new keyframe is matched against
    scan_buffer_maximum_scan_distance: float = 10.0  # buffer keyframes farther than this are left out
    # navlog's: a scan between keyframes is matched against the running buffer too (not added to the graph)
    # and its pose weighted against the odometry, at most once per minimum_time_interval (slam_toolbox's
    # name: its scans closer than this are not processed); the scans in between follow the odometry from
    # the last matched one. Off: every scan between keyframes follows the odometry from its keyframe
    match_between_keyframes: bool = True
    minimum_time_interval: float = 0.5  # s: scans between keyframes are matched at most this often
    # only every this-many-th scan of the log (and the first) may become a keyframe or be matched; the others
    # follow the odometry from the last one that was (slam_toolbox's name and meaning)
    throttle_scans: int = param(1, ge=1)
    link_match_minimum_response_fine: float = 0.1  # below it a sequential match is not trusted (odometry used)
    correlation_search_space_dimension: float = 0.5  # side of the square searched around the prediction
    correlation_search_space_resolution: float = 0.025  # cell of the correlation grid (slam_toolbox: 0.01)
    correlation_search_space_smear_deviation: float = 0.1  # std of the likelihood around every surface point
    coarse_search_angle_offset: float = 0.349  # yaw searched either side of the prediction
    coarse_angle_resolution: float = 0.0349  # yaw step of the search (refined after)
    do_loop_closing: bool = True
    loop_search_maximum_distance: float = 3.0  # keyframes closer than this are loop candidates
    # a candidate chain needs this many keyframes, or as much travel as this many made every
    # minimum_travel_distance would span (keyframes farther apart: a log recorded once per metre)
    loop_match_minimum_chain_size: int = 10
    loop_match_minimum_response_fine: float = 0.45  # a loop is accepted at or above this response
    # a search wider than loop_search_space_dimension (below) keeps its best pose at or above this response
    # before the full-resolution search around it
    loop_match_minimum_response_coarse: float = 0.35
    # side of the square searched for a loop on the correlation grid (correlation_search_space_resolution)
    loop_search_space_dimension: float = 8.0
    # navlog's: the loop search's square grows with the path's uncertainty (loop_search_path_sigmas) up to
    # this side; a square wider than loop_search_space_dimension is searched on a correlation grid coarser in
    # proportion, then at full resolution in a 1 m square around the pose it found
    loop_search_maximum_dimension: float = 20.0
    # navlog's: the loop search reaches loop_search_maximum_distance plus this many standard deviations of
    # the new keyframe's position relative to an older one (the uncertainty the sequential edges between
    # them add up to: the path's own, from the matches' covariances), up to half the loop search square
    loop_search_path_sigmas: float = 3.0
    # navlog's: where the path's uncertainty since older keyframes reaches past half of
    # loop_search_maximum_dimension (a revisit the square may not hold), a keyframe the square search did not
    # close is also matched -- the running buffer's surfaces -- against the stretch of those keyframes whose
    # ranges look most like its own, in a square over the stretch wherever the estimate puts the robot, at the
    # yaws the heading's uncertainty allows; such a closure needs loop_match_minimum_response_global, the loop's
    # other checks, and a shift within the path's uncertainty as the closures so far measured it (Slam2D's
    # _global_search)
    loop_search_global: bool = True
    # also the bar of a square search's closure that moves the keyframe farther than
    # loop_search_maximum_distance, or than half that with a look-alike place in its square: the running
    # buffer's surfaces must match there as well (Slam2D's _far, _confirmed)
    loop_match_minimum_response_global: float = 0.7
    # a loop match whose translation variance (m^2, its worst direction) exceeds this is refused: the
    # submap does not pin the scan (a corridor). slam_toolbox's name; navlog's variance is the match's
    # Hessian's (ScanMatcher.covariance), hence the smaller default (slam_toolbox: 3.0 of its own measure)
    loop_match_maximum_variance_coarse: float = 0.01
    # navlog's, after Karto's test of a loop's coarse covariance: the variance (m^2, worst direction) of the
    # positions in the searched square whose score is within 0.05 of the loop's (their best over the yaws,
    # blocks of 4 x 4 cells of the search's grid: 10 cm on the correlation grid, 25 cm on a 20 m square's
    # coarser one), weighted by that score, about their mean. A place elsewhere in the
    # square that looks the same spreads it; above this the loop is refused (counted as ambiguous)
    loop_match_maximum_spread: float = 3.0
    # navlog's: after optimising, a loop edge whose squared Mahalanobis error exceeds this is taken back
    # (the rest of the graph disagrees with it; 16.3 is chi-square's 99.9 % for three degrees of freedom)
    loop_match_maximum_chi2: float = 16.3
    map_update_interval: float = param(5.0, ge=MIN_MAP_PERIOD_S, le=MAX_PERIOD_S)  # s between /map messages
    # the /pose message's covariance (a keyframe's step: its match weighted against the odometry) times these, for
    # x and y and for the yaw (slam_toolbox's names)
    position_covariance_scale: float = param(1.0, gt=0.0)
    yaw_covariance_scale: float = param(1.0, gt=0.0)
    odom_frame: str = DEFAULT_ODOM_FRAME  # the odometry frame of the log's TF tree (slam_toolbox's name)
    # the robot's base below odom_frame (slam_toolbox's name and default); base_link when the tree has none
    base_frame: str = "base_footprint"
    # noise of the pose-graph edges (x, y, yaw standard deviations), navlog's
    # a sequential scan match: its covariance (ScanMatcher.covariance) is half the first value squared over the
    # match's Hessian -- x and y get that deviation in a room whose surfaces face both axes equally, a
    # direction the scan leaves free far more -- plus half of each of the three as a floor; the match is
    # weighted against the odometry by it
    match_sigmas: tuple[float, float, float] = (0.02, 0.02, 0.01)
    odometry_sigmas: tuple[float, float, float] = (0.1, 0.1, 0.05)  # odometry between keyframes (at first)
    # navlog's: after 20 matches, the odometry's noise is the RMS of the last 20 differences between match
    # and odometry (no less than a quarter of odometry_sigmas). Off by default: on the CARMEN datasets it
    # helps where the odometry is good (seattle ATE 0.058 -> 0.052 m) and hurts where it slips (aces 0.090 -> 0.121 m)
    estimate_odometry_noise: bool = False
    # navlog's: the odometry's increments are scaled, in length and in turn, by how the last 50 matches that pinned
    # a keyframe measured them against it (wheels whose radius or track is a few per cent off)
    calibrate_odometry: bool = True
    # navlog's: a scan taken driving away from where the laser looks (a forward-facing laser on a robot driving
    # back), more than a fifth of which the running buffer never had in sight, is matched again on the part it
    # had: its steps are measured short otherwise
    match_in_sight: bool = True
    # navlog's: odometry that has never reported driving back (wheels that may have lost the sign of their speed):
    # a match that fits less than the recent ones is tried again with the odometry's step since the last match
    # read backwards, and where that fits clearly better, the odometry's steps are read the other way from then on
    # (until a match finds them the other way again or measures the robot driving on, or the robot stops: it
    # drives on forward)
    infer_reversing: bool = True
    # a loop closure, the same way (its covariance also decides loop_match_maximum_variance_coarse)
    loop_sigmas: tuple[float, float, float] = (0.05, 0.05, 0.02)
    # the robust kernel of the loop edges in the graph: huber (measured best on the CARMEN datasets), cauchy,
    # or none (plain least squares: one false closure bends the whole graph)
    loop_kernel: Literal["huber", "cauchy", "none"] = "huber"
    loop_kernel_k: float = 1.345  # the kernel's threshold, in standard deviations

    def __post_init__(self) -> None:
        positive = (
            "resolution",
            "max_laser_range",
            "correlation_search_space_dimension",
            "correlation_search_space_resolution",
            "correlation_search_space_smear_deviation",
            "coarse_angle_resolution",
            "loop_search_space_dimension",
            "loop_search_maximum_dimension",
            "loop_match_maximum_spread",
            "map_update_interval",
            "position_covariance_scale",
            "yaw_covariance_scale",
            "loop_kernel_k",
            "loop_match_maximum_variance_coarse",
            "loop_match_maximum_chi2",
        )
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        for name in (
            "minimum_travel_distance",
            "minimum_travel_heading",
            "minimum_time_interval",
            "coarse_search_angle_offset",
            "loop_search_path_sigmas",
            "scan_buffer_maximum_scan_distance",
            "loop_search_maximum_distance",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value}")
        for name in ("odom_frame", "base_frame"):
            if not getattr(self, name).strip():
                raise ValueError(f"{name} must name a frame, got {getattr(self, name)!r}")
        if self.odom_frame == self.base_frame:
            raise ValueError(
                f"odom_frame and base_frame are both {self.odom_frame!r}: the base moves in the odometry frame"
            )
        if self.loop_kernel not in ("huber", "cauchy", "none"):
            raise ValueError(f"loop_kernel must be huber, cauchy or none, got {self.loop_kernel!r}")
        for name in ("scan_buffer_size", "loop_match_minimum_chain_size", "throttle_scans"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        wider = {
            "correlation_search_space_dimension": "a coarser correlation_search_space_resolution",
            "loop_search_space_dimension": "loop_search_maximum_dimension instead (searched on a coarser grid)",
        }
        for name, instead in wider.items():
            cells = getattr(self, name) / self.correlation_search_space_resolution
            if cells > MAX_SEARCH_CELLS:
                raise ValueError(
                    f"{name} ({getattr(self, name)} m) spans {cells:.0f} cells of correlation_search_space_resolution "
                    f"({self.correlation_search_space_resolution} m): at most {MAX_SEARCH_CELLS} (a search's grids "
                    f"grow with its square); for a wider search set {instead}"
                )
        if self.loop_search_maximum_dimension < self.loop_search_space_dimension:
            raise ValueError(
                f"loop_search_maximum_dimension ({self.loop_search_maximum_dimension}) is below "
                f"loop_search_space_dimension ({self.loop_search_space_dimension}): the square only grows from it"
            )
        for name in (
            "link_match_minimum_response_fine",
            "loop_match_minimum_response_fine",
            "loop_match_minimum_response_coarse",
            "loop_match_minimum_response_global",
        ):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} is a response in [0, 1], got {getattr(self, name)}")
        for name in ("match_sigmas", "odometry_sigmas", "loop_sigmas"):
            sig = getattr(self, name)
            if len(sig) != 3 or not all(math.isfinite(s) and s > 0 for s in sig):
                raise ValueError(f"{name} needs three positive standard deviations (x, y, yaw), got {sig}")
            if not all(SIGMA_RANGE[0] <= s <= SIGMA_RANGE[1] for s in sig):
                raise ValueError(
                    f"{name} {sig}: each standard deviation between {SIGMA_RANGE[0]} and {SIGMA_RANGE[1]} (metres, "
                    "radians)"
                )
        self._check_extents()

    def _check_extents(self) -> None:
        """Values that pass as numbers but would make a search's or a grid's arrays absurd."""
        if not MIN_GRID_RESOLUTION_M <= self.resolution <= MAX_GRID_RESOLUTION_M:
            raise ValueError(
                f"resolution ({self.resolution} m) is a map cell: between {MIN_GRID_RESOLUTION_M} and "
                f"{MAX_GRID_RESOLUTION_M} m"
            )
        res = self.correlation_search_space_resolution
        if res < MIN_GRID_RESOLUTION_M:
            raise ValueError(f"correlation_search_space_resolution ({res} m) is below {MIN_GRID_RESOLUTION_M} m")
        for name in ("correlation_search_space_dimension", "loop_search_space_dimension"):
            if getattr(self, name) < res:
                raise ValueError(
                    f"{name} ({getattr(self, name)} m) is less than one cell of correlation_search_space_resolution "
                    f"({res} m)"
                )
        # a lookup grid spans the reference the laser reaches either way, and the likelihood's reach beyond it
        side = (2 * self.max_laser_range + 6 * self.correlation_search_space_smear_deviation) / res
        if not side * side <= MAX_GRID_CELLS:
            raise ValueError(
                f"max_laser_range ({self.max_laser_range} m) and correlation_search_space_smear_deviation "
                f"({self.correlation_search_space_smear_deviation} m) make a lookup grid of {side:.3g} cells a side at "
                f"correlation_search_space_resolution {res} m: at most {MAX_GRID_CELLS:.0e} cells; set a shorter "
                "range, a smaller deviation or a coarser resolution"
            )
        if self.coarse_search_angle_offset > math.pi:
            raise ValueError(
                f"coarse_search_angle_offset ({self.coarse_search_angle_offset} rad) is more than half a turn either way"
            )
        yaws = 2 * self.coarse_search_angle_offset / self.coarse_angle_resolution + 1
        if yaws > MAX_SEARCH_YAWS:
            raise ValueError(
                f"coarse_search_angle_offset ({self.coarse_search_angle_offset} rad) over coarse_angle_resolution "
                f"({self.coarse_angle_resolution} rad) makes {yaws:.3g} yaws a search: at most {MAX_SEARCH_YAWS}"
            )
        if self.loop_search_maximum_distance > self.loop_search_maximum_dimension / 2:
            raise ValueError(
                f"loop_search_maximum_distance ({self.loop_search_maximum_distance} m) reaches past the widest loop "
                f"square (loop_search_maximum_dimension, {self.loop_search_maximum_dimension} m a side): at most half "
                "its side; widen the square too"
            )
