"""The bounds of parameters beyond which a replay or a recording would hang or exhaust memory.

Each bound is defined here once; the parameter dataclasses declare it on their fields (``param(le=...)``)
or check a product of fields in ``__post_init__`` with ``budget``, so that ``navlog check-config``
reports it as an error with the file, line and key, and a replay or recording refuses the value
before running (exit 2) with the same message. Nav2 itself declares few ranges (most of its nodes
only refuse zero or negative values, as navlog's ``gt=0`` bounds do); these upper bounds are navlog's,
chosen far above any shipped or published configuration and low enough that the largest accepted
value still finishes: a loop at ``MAX_RATE_HZ`` over an hour of log is 3.6 million cycles, a costmap
at ``MAX_COSTMAP_CELLS`` is 100 MB of costs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from navlog.replay.config import BoundError

MAX_RATE_HZ = 1000.0  # every node frequency (controller, planner, costmap update and publish, smoother, ...)
MIN_PERIOD_S = 1.0 / MAX_RATE_HZ  # any other period in seconds
MIN_MAP_PERIOD_S = 0.05  # between two published maps (a map per message would be hours on a long log)
MAX_PERIOD_S = 1e6  # any period in seconds (about 11 days: beyond it no log reaches a second tick)
MAX_COSTMAP_CELLS = 10**8  # (width / resolution) x (height / resolution): 100 MB of uint8 costs
MAX_GRID_CELLS = 10**8  # a 2D map's grid as it grows: 400 MB of float32 log-odds (500 x 500 m at 5 cm)
MIN_GRID_RESOLUTION_M = 0.005  # a 2D map's cell: finer than any laser ranges (a 1 mm grid of a room took 6.7 GB)
MAX_GRID_RESOLUTION_M = 5.0  # a 2D map's cell at most (the SLAM's map grows in blocks of 5 m)
MAX_PARTICLES = 100_000  # AMCL's particle filter (Nav2's default max_particles: 2,000)
MAX_MPPI_SAMPLES = 2_000_000  # MPPI batch_size x time_steps (Nav2's default: 1,000 x 56 = 56,000)
MAX_MPPI_ITERATIONS = 100  # MPPI iteration_count (Nav2's default: 1)
MAX_DWB_SAMPLES = 100_000  # DWB vx_samples x vy_samples x vtheta_samples (Nav2's default: 20 x 5 x 20 = 2,000)
MAX_SIM_TIME_S = 60.0  # a controller's or a safety check's look-ahead
MIN_GRANULARITY = 1e-3  # DWB's time (s), linear (m) and angular (rad) granularity of a simulated trajectory
MAX_SIMULATION_STEPS = 10_000  # collision monitor time_before_collision / simulation_time_step
MAX_GOAL_TOLERANCE_M = 10.0  # a planner's goal tolerance: its search scans (2 x tolerance / resolution)^2 cells
MAX_INFLATION_RADIUS_M = 50.0  # a costmap's inflation radius (Nav2's default: 0.55 m)
MAX_FOOTPRINT_RADIUS_M = 50.0  # a costmap footprint's farthest (padded) vertex from the robot's centre
MAX_INFLATION_CELLS = 1_000  # the inflation radius in cells: its cost table holds (radius / resolution)^2 costs
MAX_SENSOR_POINTS = 1_000_000  # beams of a recorded scan, points of a recorded LiDAR frame
# a transform's or a map origin's coordinates, at most (m): ten times the largest UTM northing a geo-referenced frame
# holds; a chain of such transforms stays far inside what a costmap's or a grid's cell arithmetic takes
MAX_TRANSLATION_M = 1e8
MAX_TRANSFORM_TOLERANCE_S = 3600.0  # added to a published transform's stamp (its seconds are 32-bit)
MAX_SEED = 2**32 - 1  # seeds are non-negative 32-bit integers (numpy's SeedSequence refuses negative ones)


def budget(key: str, what: str, value: float, limit: float, unit: str = "") -> None:
    """Raise ``BoundError`` on ``key`` when ``value`` (a product of parameters, said by ``what``) exceeds
    ``limit``: the message says the asked size and the budget."""
    if not value <= limit:  # (also NaN)
        raise BoundError(key, f"{what} = {value:,.0f}{unit} exceeds navlog's budget of {limit:,.0f}{unit}; lower it")


def check_seed(seed: int, where: str = "seed") -> int:
    """``seed`` when it is an integer in 0 .. MAX_SEED, else BoundError naming ``where``."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise BoundError(where, f"{seed!r} is out of range: a seed must be an integer from 0 to {MAX_SEED}")
    return seed


def check_finite_pose(pose: Iterable[float], where: str) -> None:
    """BoundError naming ``where`` when a pose's x, y or yaw is not a finite number."""
    values = list(pose)
    if not all(math.isfinite(float(v)) for v in values):
        raise BoundError(where, f"{values}: x, y and yaw must be finite numbers")
