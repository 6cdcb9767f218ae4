"""2D SLAM from laser scans and odometry: the algorithm slam_toolbox runs, as its steps.

Per scan (``Slam2D.add_scan``), given the odometry pose of the robot at the scan's stamp and the
scan's valid points in the robot frame:

1. **predict**: the last keyframe's pose composed with the odometry travelled since it;
2. **keyframe?** only after ``minimum_travel_distance`` or ``minimum_travel_heading`` since the last
   keyframe (the first scan with a valid reading is one); another scan is placed by the odometry since
   the last keyframe or scan a match was tried for or, at most once per ``minimum_time_interval``
   (``match_between_keyframes``), matched
   against the running buffer like a keyframe and weighted against that odometry — it is not added to
   the graph (the keyframes' graph is the same either way), but it no longer carries the odometry's
   error since its keyframe (a robot turning on the spot on slipping wheels);
3. **match** the scan against the running buffer (the last ``scan_buffer_size`` keyframes' points)
   in a ``correlation_search_space_dimension`` square around the prediction; a response below
   ``link_match_minimum_response_fine`` falls back to odometry; a scan taken driving away from where its
   laser looks is matched again on the points the buffer had in sight (``match_in_sight``);
4. **add** the keyframe to the pose graph with an edge from the previous one;
5. **close loops** (``do_loop_closing``): keyframes within ``loop_search_maximum_distance`` plus
   ``loop_search_path_sigmas`` standard deviations of the path's uncertainty since them, that are
   older than the running buffer, in a chain of at least ``loop_match_minimum_chain_size`` such
   keyframes (or as much travel as that many made every ``minimum_travel_distance`` would span: a log
   whose scans lie farther apart has fewer along a corridor it crosses), form a submap; a match of the
   new scan against it in a square as wide as the reach to the closest of them — there the uncertainty
   is the smaller of the chain's and that along the graph's shortest route, through the loops closed
   since (``_route_variance``): a revisit of a place already tied to the path searches a small square —
   (at most ``loop_search_maximum_dimension``; beyond ``loop_search_space_dimension`` searched on a
   coarser grid, then at full resolution around what it found) with a response of at least
   ``loop_match_minimum_response_fine``, that pins the scan and that no other place in the square
   matches as well (``loop_match_maximum_spread``; where the scan alone fails these two, the running
   buffer's surfaces searched in the same square stand in for it, at ``loop_match_minimum_response_global``)
   and, when it moves the keyframe farther than ``loop_search_maximum_distance`` from its estimate (or half
   that with a look-alike place in the square), that the running buffer's surfaces match there too
   (``loop_match_minimum_response_global``: a corridor one scan finds alike metres along is seldom alike
   with the metres before it), adds a loop edge, and the graph is optimised (gtsam). After
   a closure the next search waits until the keyframes have travelled ``loop_search_maximum_distance``
   (a closed loop stays closed; searching again at every keyframe of the same pass would only
   repeat it), and so does it after a closure the optimised graph disagreed with and that was taken
   back (its chain would be met again at the next keyframe);
6. **search globally** (``loop_search_global``) where the path's uncertainty outgrows the widest square:
   the running buffer is matched against the older stretch whose place signature is most alike, wherever
   the estimate puts the robot, within the uncertainty as the closures so far measured it
   (``_global_search``).

``map_to_odom`` is the correction the last keyframe implies; ``trajectory()`` is the robot's pose at
every scan with the final poses (each scan's keyframe pose composed with its pose relative to it);
``grid()`` is the occupancy grid rebuilt from the keyframes' scans at their optimised poses (the
real-scan rules of ``navlog.replay.mapping.occupancy``), kept up to date incrementally: it is
rebuilt only when an optimisation has moved a keyframe's scan by more than a map cell since it was
inserted (while the log plays, at most once per quarter more keyframes: linear work in travel).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import gtsam
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from navlog.replay.geometry import angle_diff, planar_matrix, remainder_angle
from navlog.replay.mapping.occupancy import GridTooLarge, OccupancyGrid2D, OccupancyParams
from navlog.replay.mapping.slam2d.params import SlamParams
from navlog.replay.mapping.slam2d.pose_graph import ClosedBy, PoseGraph
from navlog.replay.mapping.slam2d.rows import Rows
from navlog.replay.mapping.slam2d.scan_matcher import (
    LookupGrid,
    MatchResult,
    ScanMatcher,
    SearchWindow,
    transform_points,
)

ODOMETRY_WINDOW = 20  # matches the odometry's noise is estimated over
# calibrate_odometry: the odometry's scale is measured over the last CALIBRATION_WINDOW steps (or turns) that a
# match pinned, once CALIBRATION_WINDOW / 2 are in; steps shorter (turns smaller) than CALIBRATION_LEAST tell
# nothing of it, and a scale outside CALIBRATION_BOUNDS is not a wheel's calibration (slip): the nearer bound holds
CALIBRATION_WINDOW = 50
CALIBRATION_LEAST = (0.2, 0.1)  # m, rad
CALIBRATION_BOUNDS = (0.8, 1.25)
# a loop search wider than loop_search_space_dimension ends in a full-resolution search of this square side (m)
# and yaw either side (rad) around the pose its coarser grid found
WIDE_REFINE = (1.0, 0.1)
# m^2: a loop search whose places scoring like its match spread more than this has a look-alike in its square; such
# a closure moving its keyframe more than half loop_search_maximum_distance needs the running buffer's consent
LOOK_ALIKE_SPREAD = 1.0
# a scan's points matched at most (that many valid beams evenly spread beyond: a 2D laser has a few thousand
# beams; the matcher's work arrays grow with the points times the candidate poses)
MAX_MATCH_POINTS = 8192
# match_in_sight: a scan taken REVERSING or more away from where its laser looks since the last keyframe, more
# than UNSEEN_SHARE of whose points lie out of the running buffer's sight, is matched again on the points in
# sight (unless fewer than LEAST_IN_SIGHT of them are); a point SIGHT_MARGIN inside a buffer scan's fan, up to
# SIGHT_MARGIN beyond where its beam ended, is in its sight; a fan of FULL_FAN or more looks all round
REVERSING = 0.05  # m
REVERSAL_MISSED = 0.02  # m: a step the odometry measured forward and the scans back, each by this much or more
# infer_reversing: odometry that has reported driving back REPORTS_REVERSING in all (its steps' backward parts summed)
# knows the sign of its speed; a match whose response is DOUBTED below the median of the last ODOMETRY_WINDOW
# matches' is tried with the odometry's step since the last match (REVERSAL_MISSED or longer) read backwards, which
# is kept when its response is DOUBTED above and no more than DOUBTED below that median; a robot whose odometry
# moved slower than STOPPED between two scans stopped and drives on forward, and so does one a match measures moving
# forward REVERSAL_MISSED or more where the odometry read backwards measured as much back
REPORTS_REVERSING = 0.01  # m
DOUBTED = 0.1
STOPPED = 0.02  # m/s
SIGHT_ROUNDS = 2  # the points in sight are judged again at the pose their match found, this many times at most
UNSEEN_SHARE = 0.2
LEAST_IN_SIGHT = 0.1
SIGHT_MARGIN = 0.3  # m
FULL_FAN = math.radians(300.0)
# loop_search_global: a keyframe's place signature is the share of its valid ranges in each of SIGNATURE_BINS
# equal bins up to max_laser_range (a turn of the robot on the spot leaves it as it is); the stretch searched
# spans GLOBAL_STRETCH keyframes either side of the most alike one, at most
SIGNATURE_BINS = 32
GLOBAL_STRETCH = 10
GLOBAL_CALIBRATION = 3  # closures the square search kept before _drift_scale measures the uncertainty's scale
GLOBAL_POINTS = 1024  # the running buffer's surface points the global search matches, evenly spread, at most


@dataclass(frozen=True)
class LaserScan2D:
    """One scan as the map needs it: beams in the laser frame, the laser's mount in the robot frame."""

    angles: np.ndarray
    ranges: np.ndarray
    range_min: float
    range_max: float
    mount: np.ndarray  # 4x4 robot <- laser

    def valid(self, max_range: float) -> np.ndarray:
        """Per beam: whether its reading is valid (finite, inside the range limits and ``max_range``)."""
        r = self.ranges
        return np.isfinite(r) & (r > self.range_min) & (r < self.range_max) & (r <= max_range)

    def points(self, max_range: float, valid: np.ndarray | None = None) -> np.ndarray:
        """(N, 2) planar points of the valid readings (``valid``, computed when not given) in the robot
        frame, in beam order."""
        ok = self.valid(max_range) if valid is None else valid
        a, rr = self.angles[ok], self.ranges[ok]
        local = np.stack([rr * np.cos(a), rr * np.sin(a), np.zeros_like(rr)], axis=1)
        return local @ self.mount[:2, :3].T + self.mount[:2, 3]

    def facing(self) -> np.ndarray | None:
        """The unit vector (robot frame) the middle of the fan of beams points along; None for a fan of
        ``FULL_FAN`` or more, which looks all round."""
        if len(self.angles) < 2 or abs(float(self.angles[-1] - self.angles[0])) >= FULL_FAN:
            return None
        middle = 0.5 * float(self.angles[0] + self.angles[-1])
        look = self.mount[:2, :2] @ np.array([math.cos(middle), math.sin(middle)])
        norm = float(np.hypot(*look))
        return look / norm if norm > 1e-9 else None

    def sees(self, pose, xy: np.ndarray, margin: float, max_range: float) -> np.ndarray:
        """Per map-frame point of ``xy`` (N, 2): whether this scan, its robot at planar ``pose``, had it in
        sight: ``margin`` or more inside the edges of its fan of beams (a fan of ``FULL_FAN`` or more has
        none; a point near an edge goes in and out of sight with the pose's error), and no farther than
        ``margin`` beyond where the nearest beam (or a neighbour of it) ended: at its reading, or at
        ``range_max`` for no return (+inf, REP 117, or a reading at ``range_max`` or beyond), and never past
        ``max_range`` (the map keeps no surface beyond); a beam with an invalid reading (NaN, -inf, below
        ``range_min``) has nothing in sight. A point out of every earlier scan's sight cannot be matched
        against them: at its true place it scores nothing, and a pose that moves it onto a surface they saw
        scores more."""
        n = len(self.angles)
        out = np.zeros(len(xy), dtype=bool)
        mount = self.mount[:2, :2]
        if n < 2 or len(xy) == 0 or abs(float(np.linalg.det(mount))) < 1e-6:
            return out
        step = float(self.angles[-1] - self.angles[0]) / (n - 1)
        if not math.isfinite(step) or step == 0.0:
            return out
        c, s = math.cos(pose[2]), math.sin(pose[2])
        dx, dy = xy[:, 0] - pose[0], xy[:, 1] - pose[1]
        robot = np.stack([c * dx + s * dy, -s * dx + c * dy]) - self.mount[:2, 3:4]
        lx, ly = np.linalg.solve(mount, robot)
        distance = np.hypot(lx, ly)
        # each point's bearing from the first beam, round the circle from half a beam before it, and its beam
        half = abs(step) / 2
        turn = np.mod((np.arctan2(ly, lx) - float(self.angles[0])) * math.copysign(1.0, step) + half, 2 * math.pi)
        turn -= half
        beam = np.floor(turn / abs(step) + 0.5).astype(np.int64)
        r = np.asarray(self.ranges, dtype=np.float64)
        reach = min(float(self.range_max), max_range)
        ended = np.where(np.isfinite(r) & (r > self.range_min), np.minimum(r, reach), 0.0)
        ended[np.isposinf(r)] = reach
        widest = ended.copy()
        widest[1:] = np.maximum(widest[1:], ended[:-1])
        widest[:-1] = np.maximum(widest[:-1], ended[1:])
        if n * abs(step) >= 2 * math.pi - half:  # a full circle: past the last beam is the first
            beam %= n
            widest[0], widest[-1] = max(widest[0], ended[-1]), max(widest[-1], ended[0])
        span = (n - 1) * abs(step)
        edge = 0.0 if span >= FULL_FAN else np.minimum(margin / np.maximum(distance, 1e-9), span / 2 + half)
        inside = (turn >= edge - half) & (turn <= span + half - edge) & (beam >= 0) & (beam < n)
        ends = widest[beam[inside]]
        out[inside] = (ends > 0) & (distance[inside] <= ends + margin)
        return out


def surface_points(points: np.ndarray, spacing: float, max_gap: float) -> np.ndarray:
    """The scan's surfaces as dense points: neighbouring returns (in beam order) closer than ``max_gap``
    joined by points every ``spacing`` or less. A reference of bare returns would pull a matched scan
    towards its returns (the gaps between them read as distance); a surface does not."""
    if len(points) < 2:
        return points
    gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    join = gaps < max_gap
    steps = np.where(join, np.ceil(gaps / spacing).astype(np.int64), 1)
    starts = np.repeat(points[:-1], steps, axis=0)
    ends = np.repeat(points[1:], steps, axis=0)
    first = np.repeat(np.cumsum(steps) - steps, steps)
    frac = (np.arange(int(steps.sum())) - first) / np.repeat(steps, steps)
    frac[np.repeat(~join, steps)] = 0.0  # not joined: the return alone
    return np.concatenate([starts + (ends - starts) * frac[:, None], points[-1:]])


@dataclass
class Keyframe:
    index: int
    stamp: int  # ns
    odom: gtsam.Pose2  # the odometry pose at the stamp, as the SLAM reads it (``infer_reversing``)
    points: np.ndarray  # (N, 2) in the robot frame
    scan: LaserScan2D
    surface: np.ndarray  # (M, 2) the points joined into surfaces (``surface_points``), for matching against
    # (3, 3) map-frame covariance of its step from the keyframe before (its match weighted against the odometry, or
    # the odometry's alone); the identity for the first
    covariance: np.ndarray
    log_odom: gtsam.Pose2  # the odometry pose at the stamp as the log gives it (``map_to_odom``'s)


@dataclass
class SlamCounts:
    scans: int = 0
    keyframes: int = 0
    matched: int = 0  # sequential matches accepted
    matched_between: int = 0  # scans between keyframes placed by a match (match_between_keyframes)
    odometry_only: int = 0  # keyframes placed by odometry (no or weak match)
    loop_attempts: int = 0
    loops: int = 0
    # loop matches refused: the submap leaves a direction unpinned, or another place in the square matches as well
    loops_ambiguous: int = 0
    loops_inconsistent: int = 0  # loop edges taken back: the optimised graph disagreed with them
    global_searches: int = 0  # loop_search_global's searches (not in loop_attempts)
    loops_global: int = 0  # of the loops, those its searches closed
    # of the loops, those the running buffer's surfaces closed where the new scan's own match was ambiguous
    loops_buffer: int = 0
    empty_scans: int = 0  # scans with no valid reading (not keyframes)
    # (stamp ns, metres and radians between the odometry's prediction and the pose found, response) of every
    # keyframe whose sequential match failed and that the wider search placed: the odometry jumped or missed a turn
    odometry_jumps: list[tuple[int, float, float, float]] = field(default_factory=list)
    # stretches of consecutive keyframes placed by odometry alone (no match, even by the wider search):
    # (first keyframe, last keyframe, first stamp ns, last stamp ns)
    unplaced: list[tuple[int, int, int, int]] = field(default_factory=list)
    # keyframes left out of the map: their pose or readings lie too far off for a grid (GridTooLarge)
    off_map: set[int] = field(default_factory=set)
    # (stamp ns, the odometry's step forward m, the scans' step m, negative: back; both since the last keyframe or
    # scan a match was tried for) of every scan whose match pins x and y and measured a step back where the
    # odometry measured one forward (``REVERSAL_MISSED`` or more each): wheels that report no driving backwards
    reversals_missed: list[tuple[int, float, float]] = field(default_factory=list)
    # (stamp ns, -1: driving back, 1: forward) of every scan from which on ``infer_reversing`` read the odometry's
    # steps the other way (1 where the robot stopped)
    reversals_inferred: list[tuple[int, int]] = field(default_factory=list)


def _pose2(pose) -> gtsam.Pose2:
    return gtsam.Pose2(float(pose[0]), float(pose[1]), float(pose[2]))


def _backwards(step: gtsam.Pose2) -> gtsam.Pose2:
    """An odometry step driven the other way: its translation negated, its turn as it was."""
    return gtsam.Pose2(-step.x(), -step.y(), step.theta())


def _rotation(yaw: float) -> np.ndarray:
    """3x3 rotation of (x, y, yaw) covariances by ``yaw`` (the yaw axis stays)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _edge_covariance(cov: np.ndarray, heading: float) -> np.ndarray:
    """A map-frame (x, y, yaw) covariance of an edge's target as the edge's noise: in the frame of the target
    at ``heading`` (gtsam's ``BetweenFactorPose2`` measures its error there)."""
    rot = _rotation(heading)
    return rot.T @ cov @ rot


def _run_around(mask: np.ndarray, at: int, most: int | None = None) -> tuple[int, int]:
    """The first and last index of the run of True in ``mask`` that holds index ``at`` (True), at most ``most``
    indices either side of it when given."""
    reach = len(mask) if most is None else most
    lo = hi = at
    while lo > 0 and mask[lo - 1] and at - lo < reach:
        lo -= 1
    while hi + 1 < len(mask) and mask[hi + 1] and hi - at < reach:
        hi += 1
    return lo, hi


def _pins_position(match: MatchResult) -> bool:
    """Whether a match's response pins x and y (its Hessian's smaller eigenvalue over position above 0.1)."""
    return float(np.linalg.eigvalsh(match.hessian[:2, :2])[0]) > 0.1


def _xyt(p: gtsam.Pose2) -> np.ndarray:
    return np.array([p.x(), p.y(), p.theta()])


class Slam2D:
    """The SLAM state: keyframes, their pose graph, the map (see the module docstring)."""

    def __init__(self, params: SlamParams, grid: OccupancyParams | None = None) -> None:
        self.p = params
        grid = grid or OccupancyParams(resolution=params.resolution)
        if grid.max_laser_range == 0:  # the map is drawn to the laser range the scans are matched to
            grid = replace(grid, max_laser_range=params.max_laser_range)
        self.grid_params = grid
        self.matcher = ScanMatcher(
            params.correlation_search_space_resolution, params.correlation_search_space_smear_deviation
        )
        self.graph = PoseGraph()
        self.keyframes: list[Keyframe] = []
        self.counts = SlamCounts()
        # per scan: (stamp, its keyframe, its pose in the keyframe's frame)
        self._scans: list[tuple[int, int, gtsam.Pose2]] = []
        # the last keyframe or scan a match was tried for (placed by it, or by the odometry when it failed):
        # (stamp, odometry pose, pose in its keyframe's frame)
        self._anchor: tuple[int, gtsam.Pose2, gtsam.Pose2] = (0, gtsam.Pose2(), gtsam.Pose2())
        # the odometry as the SLAM reads it (infer_reversing): the log's pose and stamp at the last scan, the pose
        # read there, the way its steps are read (1 as given, -1 backwards), how far the log's odometry has reported
        # driving back in all, the read pose of the log's frame origin while read as given after a reversal, the
        # keyframes when the reading last turned, and the last matches' responses
        self._log_odom: gtsam.Pose2 | None = None
        self._log_stamp = 0
        self._odom = gtsam.Pose2()
        self._direction = 1
        self._reported_back = 0.0
        self._read_origin: gtsam.Pose2 | None = None
        self._turned_at = -1
        self._responses: deque[float] = deque(maxlen=ODOMETRY_WINDOW)
        self._between: tuple[tuple[int, int], LookupGrid] | None = None  # see _between_grid
        self._grid = OccupancyGrid2D(self.grid_params)
        self._grid_poses = np.zeros((0, 3))  # the poses the keyframes in _grid were inserted at
        self._grid_drawn = 0  # keyframes when the grid was last redrawn from scratch
        self._since_loop = math.inf  # path length of keyframes since the last loop closure
        self._since_global = math.inf  # path length of keyframes since the last global search (loop_search_global)
        # the last keyframes' odometry travel to them (the newest and ODOMETRY_WINDOW before it)
        self._odometry_steps: deque[float] = deque(maxlen=ODOMETRY_WINDOW + 1)
        # the last matches' match - odometry prediction, in the previous keyframe's frame
        self._innovations: deque[np.ndarray] = deque(maxlen=ODOMETRY_WINDOW)
        # calibrate_odometry: (matched, odometry) step lengths, and (matched, odometry) turns signed by the odometry's
        self._lengths: deque[tuple[float, float]] = deque(maxlen=CALIBRATION_WINDOW)
        self._turns: deque[tuple[float, float]] = deque(maxlen=CALIBRATION_WINDOW)
        self._scales = (1.0, 1.0)  # the length and turn scales those measure (see _calibration_sample)
        self._travel: list[float] = [0.0]  # per keyframe: path length from the first, as estimated when added
        # per keyframe: the covariance of its sequential edge (in its own frame, as the edge measures it; zero for
        # the first)
        self._chain_cov = Rows((3, 3))
        self._chain_cov.append(np.zeros((3, 3)))
        # per loop closure kept: (old keyframe, new keyframe, its translation variance's trace, its yaw variance)
        self._loop_edges = Rows((4,))
        # per loop closure the square search kept: how far its match put the new keyframe from its estimate, in
        # standard deviations of the path's uncertainty (loop_search_global's measure of that uncertainty's scale)
        self._drift_ratios: list[float] = []
        self._signatures = Rows((SIGNATURE_BINS,))  # per keyframe: its place signature (_signature)
        self._map_points: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # keyframe -> (pose, its points there)
        self._range_max: list[float] = []  # per keyframe: the longest range_max of the scans up to it
        self._link = SearchWindow(
            params.correlation_search_space_dimension, params.coarse_search_angle_offset, params.coarse_angle_resolution
        )

    # ------------------------------------------------------------ the steps
    def add_scan(self, stamp: int, odom_pose, scan: LaserScan2D) -> np.ndarray | None:
        """Process one scan; returns the robot's pose (x, y, yaw) in the map frame at its stamp (None for a
        scan with no valid reading before the first keyframe: nothing places it). Odometry that is not
        finite raises ``ValueError`` (the caller skips such scans)."""
        if not all(math.isfinite(float(v)) for v in odom_pose):
            raise ValueError(f"odometry pose not finite: {tuple(odom_pose)}")
        self.counts.scans += 1
        odom = self._read_odometry(stamp, _pose2(odom_pose))
        prediction = self._predict(odom)
        # throttle_scans: a scan it passes over is placed like a scan between keyframes that no match is due for
        processed = not self.keyframes or self.counts.scans % self.p.throttle_scans == 0
        keyframe = not self.keyframes or (processed and self._travelled(odom))
        valid = scan.valid(self.p.max_laser_range)
        points = None
        if not valid.any():
            self.counts.empty_scans += 1
            if not self.keyframes:
                return None
            keyframe = False
        elif keyframe or (processed and self._match_due(stamp)):
            points = scan.points(self.p.max_laser_range, valid)
            if len(points) > MAX_MATCH_POINTS:
                points = points[np.linspace(0, len(points) - 1, MAX_MATCH_POINTS).astype(np.int64)]
        # matched (points given) driving away from where the laser looks
        reversing = (
            points is not None and bool(self.keyframes) and self._reversing(scan, self.keyframes[-1].odom.between(odom))
        )
        if not keyframe:
            return self._between_keyframes(stamp, odom, points, scan, reversing)
        assert points is not None
        pose = self._add_keyframe(stamp, odom, points, scan, prediction, reversing)
        if self.p.do_loop_closing:
            self._close_loop()
        self._scans.append((stamp, len(self.keyframes) - 1, gtsam.Pose2()))
        self._anchor = (stamp, odom, gtsam.Pose2())
        return _xyt(self._pose(len(self.keyframes) - 1)) if self.graph.optimizations else pose

    def _match_due(self, stamp: int) -> bool:
        """Whether a scan between keyframes is to be matched (``match_between_keyframes``, and at least
        ``minimum_time_interval`` since the last keyframe or scan a match was tried for)."""
        return self.p.match_between_keyframes and stamp - self._anchor[0] >= self.p.minimum_time_interval * 1e9

    def _between_keyframes(
        self, stamp: int, odom: gtsam.Pose2, points: np.ndarray | None, scan: LaserScan2D, reversing: bool
    ) -> np.ndarray:
        """A scan that is no keyframe: placed by the odometry since the last keyframe or scan a match was tried
        for (its *anchor*) or,
        given its points, matched against the running buffer and weighted against that odometry; kept as
        its pose relative to the last keyframe, so that it follows the keyframe when the graph moves it."""
        last = self.keyframes[-1]
        base = self._pose(last.index)
        _, _, anchor_rel = self._anchor
        start, step = self._from_anchor(odom)
        rel = anchor_rel.compose(step)
        pose = _xyt(base.compose(rel))
        if points is not None and len(points):
            grid = self._between_grid(base)
            match = self._sequential_match(grid, points, pose, base, reversing)
            other, back = self._sign_checked(grid, points, match, step, start, scan, stamp, reversing, False)
            if other is not None and back is not None:
                match, pose = other, back
            if match is not None:
                if _pins_position(match):
                    self._check_reversal(stamp, odom, match, base)
                pose, _ = self._fuse(pose, base.theta(), match)
                rel = base.between(_pose2(pose))
                self.counts.matched_between += 1
            self._anchor = (stamp, odom, rel)
        self._scans.append((stamp, last.index, rel))
        return pose

    def _between_grid(self, base: gtsam.Pose2) -> LookupGrid:
        """The running buffer's lookup grid for the scans between the last keyframe and the next (made once
        per keyframe, and again when an optimisation moved the keyframes): the buffer's points within reach
        of any such scan, among them all of the last keyframe's own."""
        key = (len(self.keyframes), self.graph.optimizations)
        if self._between is None or self._between[0] != key:
            reference = self._buffer_points(base)
            # a scan before the next keyframe lies less than minimum_travel_distance (by odometry) from the
            # keyframe, its laser the mount's offset from its base, its points max_laser_range from the laser;
            # a full window's side covers the matches' corrections on the way
            mount = self.keyframes[-1].scan.mount
            reach = (
                self.p.max_laser_range
                + math.hypot(float(mount[0, 3]), float(mount[1, 3]))
                + self.p.minimum_travel_distance
                + self._link.linear
                + 4 * self.p.correlation_search_space_smear_deviation
            )
            reference = reference[np.hypot(reference[:, 0] - base.x(), reference[:, 1] - base.y()) <= reach]
            self._between = (key, self.matcher.grid(reference, self._link))
        return self._between[1]

    def _read_odometry(self, stamp: int, log_odom: gtsam.Pose2) -> gtsam.Pose2:
        """The odometry pose as the SLAM reads it at a scan of ``stamp`` whose log pose is ``log_odom``: as given
        until ``infer_reversing`` reads a step backwards (``_sign_checked``), then the steps since chained, each
        backwards while the robot is taken to drive back (its translation negated, its turn as given): until a
        match finds it driving forward (``_sign_checked``, ``_check_reversal``), or it stops (its odometry slower
        than ``STOPPED`` since the last scan), or the log's odometry reports driving back after all
        (``REPORTS_REVERSING``: it knows the sign)."""
        previous = self._log_odom
        elapsed, self._log_stamp = (stamp - self._log_stamp) * 1e-9, stamp
        if previous is None:
            self._odom = self._log_odom = log_odom
            return log_odom
        step = previous.between(log_odom)
        self._reported_back += max(0.0, -step.x())
        stopped = math.hypot(step.x(), step.y()) < STOPPED * elapsed
        if self._direction < 0 and (stopped or self._reported_back >= REPORTS_REVERSING):
            self._turn_reading(stamp)  # (from the last scan's poses; odometry that reports driving back is as given)
        self._log_odom = log_odom
        if self._direction < 0:
            self._odom = self._odom.compose(_backwards(step))
        elif self._read_origin is not None:
            self._odom = self._read_origin.compose(log_odom)
        else:
            self._odom = log_odom
        return self._odom

    def _turn_reading(self, stamp: int) -> None:
        """From the scan of ``stamp`` on, read the odometry's steps the other way (``_read_odometry``)."""
        assert self._log_odom is not None  # a scan was read
        self._direction = -self._direction
        self.counts.reversals_inferred.append((stamp, self._direction))
        self._turned_at = len(self.keyframes)
        if self._direction > 0:
            self._read_origin = self._odom.compose(self._log_odom.inverse())

    def _sign_checked(
        self,
        grid: LookupGrid | None,
        points: np.ndarray,
        match: MatchResult | None,
        step: gtsam.Pose2,
        start: gtsam.Pose2,
        scan: LaserScan2D,
        stamp: int,
        reversing: bool,
        keyframe: bool,
    ) -> tuple[MatchResult | None, np.ndarray | None]:
        """``infer_reversing``: given the sequential ``match`` of a scan (on ``grid``), the match of the scan
        predicted at ``start`` (the anchor's pose) composed with the odometry's ``step`` since the anchor read
        backwards, and that prediction, when ``match`` fits ``DOUBTED`` less than the last matches did (or failed),
        the step is ``REVERSAL_MISSED`` or longer and the step backwards fits ``DOUBTED`` better than the step as
        read and as the last matches did, less ``DOUBTED`` (a scan that fits nowhere near, a turn the odometry
        missed, is no reversal), pinning x and y; else (None, None). Fits are the whole scan's response at the pose found (a match of
        the points in sight, ``match_in_sight``, which ``reversing`` says ``match`` may be, scores only those). A
        ``keyframe``'s match is predicted from the last keyframe: both predictions from ``start`` are matched, each
        on a grid around itself."""
        if not self.p.infer_reversing or self._reported_back >= REPORTS_REVERSING:
            return None, None
        fit = 0.0 if match is None or grid is None else match.response
        if reversing and match is not None and grid is not None:
            fit = grid.response(match.pose, points)
        if match is not None:
            self._responses.append(fit)
        if len(self._responses) < ODOMETRY_WINDOW // 2 or math.hypot(step.x(), step.y()) < REVERSAL_MISSED:
            return None, None
        usual = float(np.median(self._responses))
        if fit > usual - DOUBTED:
            return None, None
        if match is not None and grid is not None and not reversing:  # (a match in sight was scored whole above)
            fit = grid.response(match.pose, points)
        back = _xyt(start.compose(_backwards(step)))
        if keyframe:
            ahead = _xyt(start.compose(step))
            grid = self.matcher.grid_around(self._buffer_points(_pose2(ahead)), points, ahead, self._link)
            found = self._sequential_match(grid, points, ahead, _pose2(ahead), self._reversing(scan, step))
            fit = 0.0 if found is None or grid is None else grid.response(found.pose, points)
            grid = self.matcher.grid_around(self._buffer_points(_pose2(back)), points, back, self._link)
        other = self._sequential_match(grid, points, back, _pose2(back), self._reversing(scan, _backwards(step)))
        if other is None or grid is None or not _pins_position(other):
            return None, None
        other_fit = grid.response(other.pose, points)
        if other_fit < fit + DOUBTED or other_fit < usual - DOUBTED:
            return None, None
        if match is not None:
            self._responses.pop()
        self._responses.append(other_fit)
        self._turn_reading(stamp)
        return other, back

    def _predict(self, odom: gtsam.Pose2) -> gtsam.Pose2:
        if not self.keyframes:
            return odom  # the map frame starts where the odometry frame is
        last = self.keyframes[-1]
        if self._turned_at == len(self.keyframes):  # the reading turned since the last keyframe: from the anchor
            start, step = self._from_anchor(odom)
            return start.compose(step)
        return self._pose(last.index).compose(self._calibrated(last.odom.between(odom)))

    def _from_anchor(self, odom: gtsam.Pose2) -> tuple[gtsam.Pose2, gtsam.Pose2]:
        """The anchor's map pose (the last keyframe's composed with the anchor's pose in its frame) and the
        odometry's calibrated step from the anchor to ``odom``."""
        _, anchor_odom, anchor_rel = self._anchor
        return self._pose(self.keyframes[-1].index).compose(anchor_rel), self._calibrated(anchor_odom.between(odom))

    def _calibration_sample(self, matched: gtsam.Pose2, odometry: gtsam.Pose2) -> None:
        """A keyframe's step as a match that pinned it measured it and as the odometry did (both in the previous
        keyframe's frame), for ``calibrate_odometry``. A step driven backwards is no sample: a laser facing
        forward measures it short, a little even matched on what the buffer had in sight (``_in_sight``)."""
        length = math.hypot(odometry.x(), odometry.y())
        if odometry.x() < -CALIBRATION_LEAST[0] / 4:
            return
        if length >= CALIBRATION_LEAST[0]:
            self._lengths.append((math.hypot(matched.x(), matched.y()), length))
        if abs(odometry.theta()) >= CALIBRATION_LEAST[1]:
            sign = 1.0 if odometry.theta() > 0 else -1.0
            self._turns.append((sign * matched.theta(), sign * odometry.theta()))
        # per kind, the matched sum over the odometry's, held within the bounds; 1 until CALIBRATION_WINDOW / 2 are in
        scales = []
        for samples in (self._lengths, self._turns):
            if len(samples) < CALIBRATION_WINDOW // 2:
                scales.append(1.0)
            else:
                matched_sum, odometry_sum = (sum(v) for v in zip(*samples, strict=True))
                scales.append(min(max(matched_sum / odometry_sum, CALIBRATION_BOUNDS[0]), CALIBRATION_BOUNDS[1]))
        self._scales = (scales[0], scales[1])

    def _calibrated(self, step: gtsam.Pose2) -> gtsam.Pose2:
        """An odometry increment with its length and its turn scaled by the odometry's measured scales
        (``calibrate_odometry``: over the last ``CALIBRATION_WINDOW`` keyframe steps, and turns, a match pinned:
        the matched sum over the odometry's; 1 until ``CALIBRATION_WINDOW / 2`` are in): wheels whose radius or
        track is off by a few per cent, which a match corrects where it pins the pose but not along a
        corridor's axis, where the odometry decides."""
        length, turn = self._scales
        if not self.p.calibrate_odometry or (length, turn) == (1.0, 1.0):
            return step
        return gtsam.Pose2(length * step.x(), length * step.y(), turn * step.theta())

    def _travelled(self, odom: gtsam.Pose2) -> bool:
        d = self.keyframes[-1].odom.between(odom)
        return (
            math.hypot(d.x(), d.y()) >= self.p.minimum_travel_distance
            or abs(d.theta()) >= self.p.minimum_travel_heading
        )

    def _check_reversal(self, stamp: int, odom: gtsam.Pose2, match: MatchResult, last: gtsam.Pose2) -> None:
        """Given a scan's match that pins x and y, and the step it measured along the robot's heading since the
        anchor (the last keyframe or scan a match was tried for, at its pose then; ``last`` is the last keyframe's
        pose): count the scan in ``counts.reversals_missed`` when the match measured a step back of
        ``REVERSAL_MISSED`` or more where the odometry as read measured one forward as long; and, while the
        odometry is read backwards (``infer_reversing``), turn the reading forward from this scan on when the
        match measured a step forward that long where the reading measured one back (the robot drives on)."""
        _, anchor_odom, anchor_rel = self._anchor
        read = anchor_odom.between(odom).x()
        if abs(read) < REVERSAL_MISSED:
            return
        moved = last.compose(anchor_rel).between(_pose2(match.pose)).x()
        if read > 0 and moved <= -REVERSAL_MISSED:
            self.counts.reversals_missed.append((stamp, float(read), float(moved)))
        elif read < 0 and moved >= REVERSAL_MISSED and self._direction < 0:
            self._turn_reading(stamp)

    def _add_keyframe(
        self,
        stamp: int,
        odom: gtsam.Pose2,
        points: np.ndarray,
        scan: LaserScan2D,
        prediction: gtsam.Pose2,
        reversing: bool,
    ) -> np.ndarray:
        i = len(self.keyframes)
        pose = _xyt(prediction)
        cov = np.eye(3)
        if i == 0:
            self.graph.add_node(pose)
        else:
            grid = self.matcher.grid_around(self._buffer_points(prediction), points, pose, self._link)
            match = self._sequential_match(grid, points, pose, prediction, reversing)
            start, since = self._from_anchor(odom)
            other, back = self._sign_checked(grid, points, match, since, start, scan, stamp, reversing, True)
            if other is not None and back is not None:
                match, pose, prediction = other, back, _pose2(back)
            prev = self._pose(i - 1)
            rot = _rotation(prev.theta())
            recovered = None
            step = self.keyframes[-1].odom.between(odom)
            self._odometry_steps.append(math.hypot(step.x(), step.y()))
            weak = match is None or match.response < self.p.loop_match_minimum_response_fine
            usual = self._usual_step()
            halfway = (1.0 + (0.0 if match is None else match.response)) / 2
            if weak:  # the wider searches, against the running buffer, for a response halfway to 1 at least
                reference = self._buffer_points(prev)
                least = max(self.p.loop_match_minimum_response_fine, halfway)
                if math.isinf(usual) or self._odometry_steps[-1] > usual:  # early in a log, any step may be
                    recovered = self._recover(reference, points, pose, _xyt(prev), least, usual)
                if recovered is None:
                    recovered = self._recover_turn(reference, points, pose, least, usual)
            if recovered is not None:  # the odometry jumped: the scans say where the robot is
                turn = remainder_angle(float(recovered.pose[2] - pose[2]))
                distance = float(np.linalg.norm(recovered.pose[:2] - pose[:2]))
                self.counts.odometry_jumps.append((stamp, distance, turn, float(recovered.response)))
                pose = recovered.pose.copy()
                pose[2] = remainder_angle(float(pose[2]))
                self.counts.matched += 1
                cov = self._match_covariance(recovered, self.p.match_sigmas)
                kind, response = "match", recovered.response
            elif match is not None:
                if _pins_position(match):
                    self._check_reversal(stamp, odom, match, prev)
                    innovation = rot.T @ (match.pose - pose)
                    innovation[2] = remainder_angle(float(innovation[2]))
                    self._innovations.append(innovation)
                    # a reading turned since the last keyframe (here or at a scan between) read its step partly the
                    # other way: no sample
                    if self._turned_at != i:
                        self._calibration_sample(prev.between(_pose2(match.pose)), step)
                pose, cov = self._fuse(pose, prev.theta(), match)
                self.counts.matched += 1
                kind, response = "match", match.response
            else:
                self.counts.odometry_only += 1
                self._unplaced(i, stamp)
                cov, kind, response = self._odometry_covariance(prev.theta()), "odometry", 0.0
            noise = _edge_covariance(cov, pose[2])
            self.graph.add_node(pose)
            rel = prev.between(_pose2(pose))
            self.graph.add_edge(i - 1, i, _xyt(rel), noise, kind, response=response)  # type: ignore[arg-type]
            self._chain_cov.append(noise)
            self._travel.append(self._travel[-1] + float(np.linalg.norm(pose[:2] - _xyt(prev)[:2])))
        res = self.p.correlation_search_space_resolution
        surface = surface_points(points, res / 2, self.p.correlation_search_space_smear_deviation * 1.5)
        assert self._log_odom is not None  # add_scan read it
        self.keyframes.append(Keyframe(i, stamp, odom, points, scan, surface, cov, self._log_odom))
        self._signatures.append(self._signature(scan))
        self._range_max.append(
            max(self._range_max[-1], float(scan.range_max)) if self._range_max else float(scan.range_max)
        )
        self.counts.keyframes += 1
        return pose

    def _recover(
        self,
        reference: np.ndarray,
        points: np.ndarray,
        prediction: np.ndarray,
        previous: np.ndarray,
        least: float,
        usual: float,
    ) -> MatchResult | None:
        """After a failed or weak sequential match: the scan matched against the running buffer (``reference``) in a
        ``loop_search_space_dimension`` square around the odometry's prediction, then around the
        previous keyframe's position with the prediction's heading and, when the two differ by more than the
        search's fan, with the previous keyframe's own (odometry that jumped or was reset while the robot
        stood still or drove on); the first place found that (1) pins the scan
        (``loop_match_maximum_variance_coarse``) with a response of at least ``least`` (the caller's: at least
        ``loop_match_minimum_response_fine`` and halfway from the weak match's response to 1, so that a slightly
        better fit elsewhere in a large hall does not move the robot), (2) lies outside the sequential
        search (inside it, the sequential match's verdict stands) and (3) is a ``usual`` step from the
        previous keyframe (it is the odometry that jumped, not the robot). None when no place passes (the
        scans do not overlap what came before: the robot was carried off)."""
        window = SearchWindow(
            self.p.loop_search_space_dimension, self.p.coarse_search_angle_offset, self.p.coarse_angle_resolution
        )
        centres = [prediction, np.array([previous[0], previous[1], prediction[2]])]
        if abs(remainder_angle(float(previous[2] - prediction[2]))) > self._link.angular:
            centres.append(np.asarray(previous, dtype=np.float64))
        for centre in centres:
            found = self.matcher.match(reference, points, centre, window, least)
            if found is None:
                continue
            pinned = self._pins(self._match_covariance(found, self.p.loop_sigmas))
            turn = abs(remainder_angle(float(found.pose[2] - prediction[2])))
            inside = np.max(np.abs(found.pose[:2] - prediction[:2])) <= self._link.linear / 2 and turn <= (
                self._link.angular
            )
            step = float(np.linalg.norm(found.pose[:2] - previous[:2]))
            if pinned and not inside and step <= usual:
                return found
        return None

    def _recover_turn(
        self, reference: np.ndarray, points: np.ndarray, prediction: np.ndarray, least: float, usual: float
    ) -> MatchResult | None:
        """After a failed or weak sequential match: the scan matched against the running buffer (``reference``) at
        every heading, within a ``usual`` step either way of the odometry's prediction (the sequential search's
        square at least, ``loop_search_space_dimension`` at most), for a heading outside the search's fan with a
        response of at least ``least`` (the caller's, as for ``_recover``) that no heading outside the fan around
        it reaches as well: the robot turned and the odometry did not see it (a gyro that lost its heading, a gap
        in the log while the robot turned). Where the fit leaves a direction free (a corridor), the pose keeps the
        odometry's prediction along it. None when none passes."""
        side = min(self.p.loop_search_space_dimension, max(self._link.linear, 2.0 * usual))
        fan = self._link.angular
        every = replace(self._link, linear=side, angular=math.pi)
        found = self.matcher.match(reference, points, prediction, every, least)
        if found is None or abs(remainder_angle(float(found.pose[2] - prediction[2]))) <= fan:
            return None
        # every heading more than the fan away from the fit's: a second heading as good is a look-alike (a corridor
        # seen either way), not a turn
        others = replace(self._link, linear=side, angular=math.pi - fan)
        if self.matcher.match(reference, points, found.pose + np.array([0.0, 0.0, math.pi]), others, least) is not None:
            return None
        cov = self._match_covariance(found, self.p.loop_sigmas)
        values, vectors = np.linalg.eigh(cov[:2, :2])
        if values[-1] > self.p.loop_match_maximum_variance_coarse:  # the odometry's place along the free axis
            free = vectors[:, -1]
            pose = found.pose.copy()
            pose[:2] += free * float(free @ (prediction[:2] - found.pose[:2]))
            found = replace(found, pose=pose)
        return found

    def _signature(self, scan: LaserScan2D) -> np.ndarray:
        """The scan's place signature (``SIGNATURE_BINS``): the share of its valid ranges in each bin."""
        valid = scan.valid(self.p.max_laser_range)
        counts, _ = np.histogram(scan.ranges[valid], bins=SIGNATURE_BINS, range=(0.0, self.p.max_laser_range))
        return counts / max(1, int(valid.sum()))

    def _usual_step(self) -> float:
        """The longest usual step between keyframes: half the sequential search square or twice the median of
        the odometry's last ``ODOMETRY_WINDOW`` steps, whichever is longer (infinite before ``ODOMETRY_WINDOW /
        2`` steps). An odometry jump is an unusual odometry step to a place the scans reach by a usual one:
        where the odometry moved as it usually does, or the scans' place needs an unusual step too, a better
        fit far away is a look-alike place (a robot reversing with a forward-facing laser meets many)."""
        recent = list(self._odometry_steps)[:-1]
        if len(recent) < ODOMETRY_WINDOW // 2:
            return math.inf
        return max(self._link.linear / 2, 2.0 * float(np.median(recent)))

    def _unplaced(self, i: int, stamp: int) -> None:
        """Keyframe ``i`` is placed by odometry alone: it extends the current stretch or starts one."""
        stretches = self.counts.unplaced
        if stretches and stretches[-1][1] == i - 1:
            first, _, start, _ = stretches[-1]
            stretches[-1] = (first, i, start, stamp)
        else:
            stretches.append((i, i, stamp, stamp))

    def _odometry_sigmas(self) -> np.ndarray:
        """The odometry's noise between keyframes: ``odometry_sigmas`` until ``ODOMETRY_WINDOW`` matches
        are in, then (``estimate_odometry_noise``) the RMS of the last ``ODOMETRY_WINDOW`` differences between
        the match and the odometry's prediction, per axis, no less than a quarter of ``odometry_sigmas``."""
        configured = np.asarray(self.p.odometry_sigmas, dtype=np.float64)
        if not self.p.estimate_odometry_noise or len(self._innovations) < ODOMETRY_WINDOW:
            return configured
        recent = np.array(self._innovations)
        return np.maximum(np.sqrt(np.mean(np.square(recent), axis=0)), 0.25 * configured)

    def _match_covariance(self, match: MatchResult, sigmas: tuple[float, float, float]) -> np.ndarray:
        """A match's map-frame covariance under ``match_sigmas`` or ``loop_sigmas`` (``ScanMatcher.covariance``)."""
        return self.matcher.covariance(match, sigmas[0], 0.5 * np.asarray(sigmas))

    def _pins(self, cov: np.ndarray) -> bool:
        """Whether a match of covariance ``cov`` pins the scan: its translation variance in the worst direction
        is at most ``loop_match_maximum_variance_coarse`` (a corridor's axis is not)."""
        return float(np.linalg.eigvalsh(cov[:2, :2])[-1]) <= self.p.loop_match_maximum_variance_coarse

    def _odometry_covariance(self, heading: float) -> np.ndarray:
        """The odometry's covariance since the keyframe at ``heading`` (``_odometry_sigmas`` in its frame), in
        the map frame."""
        rot = _rotation(heading)
        return rot @ np.diag(np.square(self._odometry_sigmas())) @ rot.T

    def _fuse(self, prediction: np.ndarray, heading: float, match: MatchResult) -> tuple[np.ndarray, np.ndarray]:
        """The match weighted against the odometry prediction by their covariances (map frame; the odometry's,
        ``_odometry_sigmas`` in the frame of the keyframe at ``heading`` it was predicted from): the pose and
        its covariance. Where the scan pins the pose the match wins; along a direction it leaves free (a
        corridor's axis) the odometry does."""
        info_m = np.linalg.inv(self._match_covariance(match, self.p.match_sigmas))
        info_o = np.linalg.inv(self._odometry_covariance(heading))
        cov = np.linalg.inv(info_m + info_o)
        diff = match.pose - prediction
        diff[2] = remainder_angle(float(diff[2]))
        pose = prediction + cov @ info_m @ diff
        pose[2] = remainder_angle(float(pose[2]))
        return pose, 0.5 * (cov + cov.T)

    def _buffer(self, around: gtsam.Pose2) -> list[int]:
        """The running buffer: the last ``scan_buffer_size`` keyframes within the buffer distance of ``around``."""
        recent = self.keyframes[-self.p.scan_buffer_size :]
        centre = np.array([around.x(), around.y()])
        return [
            k.index
            for k in recent
            if np.linalg.norm(self._pose_xy(k.index) - centre) <= self.p.scan_buffer_maximum_scan_distance
        ]

    def _buffer_points(self, around: gtsam.Pose2) -> np.ndarray:
        """The running buffer's points in the map frame."""
        return self._points_of(self._buffer(around))

    def _reversing(self, scan: LaserScan2D, step: gtsam.Pose2) -> bool:
        """Whether odometry ``step`` (since the last keyframe, robot frame) took the robot ``REVERSING`` or more
        away from where ``scan``'s laser looks (``match_in_sight``; never for a laser that looks all round)."""
        look = scan.facing() if self.p.match_in_sight else None
        return look is not None and float(look[0] * step.x() + look[1] * step.y()) <= -REVERSING

    def _sequential_match(
        self, grid: LookupGrid | None, points: np.ndarray, pose: np.ndarray, around: gtsam.Pose2, reversing: bool
    ) -> MatchResult | None:
        """A scan matched in the sequential window around ``pose`` against the running buffer around ``around``
        (its lookup ``grid``): None when no pose reaches ``link_match_minimum_response_fine``. A scan taken
        ``reversing`` (``_reversing``) whose points at the pose found lie too much out of the buffer's sight
        (``_in_sight``) is matched again, around that pose, on the points in sight, and again on the points in
        sight at the pose that found (the first pose, pulled towards the surfaces the buffer saw, keeps some of
        the points it pulled there in sight), ``SIGHT_ROUNDS`` times at most, until they no longer change: the
        last match, its response and Hessian those of its points in sight (the whole scan, part of it out of
        sight, fits less, and a weak response sends the scan looking for another place: ``_recover``), as
        long as the whole scan fits it at ``link_match_minimum_response_fine`` or more."""
        if grid is None:
            return None
        least = self.p.link_match_minimum_response_fine
        match = self.matcher.match_on(grid, points, pose, self._link, least)
        if match is None:
            return None
        if not reversing:
            return match
        found, previous = match, None
        for _ in range(SIGHT_ROUNDS):
            sighted = self._in_sight(points, found.pose, around)
            if len(sighted) == len(points) or (previous is not None and np.array_equal(sighted, previous)):
                break
            again = self.matcher.match_on(grid, sighted, found.pose, self._link, least)
            if again is None or grid.response(again.pose, points) < least:
                break
            found, previous = again, sighted
        return found

    def _in_sight(self, points: np.ndarray, pose: np.ndarray, around: gtsam.Pose2) -> np.ndarray:
        """The scan's points to match against the running buffer around ``around``: with more than
        ``UNSEEN_SHARE`` of them out of the buffer's sight when placed at ``pose`` (``LaserScan2D.sees``), those
        in sight -- a scan matched with many points its reference never had in sight is pulled towards poses
        that put them on its surfaces: a laser facing forward on a robot driving back measures every step
        short; else, or when fewer than ``LEAST_IN_SIGHT`` of them are in sight, all of them."""
        if len(points) == 0:
            return points
        xy = transform_points(pose, points)
        seen = np.zeros(len(points), dtype=bool)
        for i in self._buffer(around):
            seen |= self.keyframes[i].scan.sees(self.graph.pose(i), xy, SIGHT_MARGIN, self.p.max_laser_range)
        share = float(seen.mean())
        if share >= 1.0 - UNSEEN_SHARE or share < LEAST_IN_SIGHT:
            return points
        return points[seen]

    def _points_of(self, indices: list[int]) -> np.ndarray:
        """The keyframes' surfaces in the map frame, at their current poses."""
        parts = []
        for i in indices:
            pose = self.graph.pose(i)
            cached = self._map_points.get(i)
            if cached is None or not np.array_equal(cached[0], pose):
                cached = self._map_points[i] = (pose, transform_points(pose, self.keyframes[i].surface))
            parts.append(cached[1])
        return np.concatenate(parts) if parts else np.zeros((0, 2))

    def _close_loop(self) -> None:
        new = len(self.keyframes) - 1
        if new > 0:
            step = self._travel[new] - self._travel[new - 1]
            self._since_loop += step
            self._since_global += step
        if self._since_loop < self.p.loop_search_maximum_distance:
            return
        old_end = new - self.p.scan_buffer_size  # keyframes before this are not in the running buffer
        if old_end <= 0:
            return
        poses = self.graph.poses()
        d = np.linalg.norm(poses[:old_end, :2] - poses[new, :2], axis=1)
        # the search reaches as far as the path's uncertainty since a keyframe may have carried the estimate
        # off it: the fixed distance plus loop_search_path_sigmas standard deviations of the new keyframe's
        # position relative to it, bounded by the loop search window
        path = self._path_variance(poses, new)[:old_end]
        full = self.p.loop_search_maximum_distance + self.p.loop_search_path_sigmas * np.sqrt(path)
        reach = np.minimum(full, self.p.loop_search_maximum_dimension / 2)
        near = d <= reach
        searched = np.zeros(old_end, dtype=bool)
        variance = None  # the least of the chain's and the route's variance (_least_variance), once needed
        if near.any():
            closest = int(np.argmin(np.where(near, d / reach, np.inf)))
            lo, hi = _run_around(near, closest)  # the chain: near keyframes contiguous with the closest one
            if self._submap(lo, hi):
                self.counts.loop_attempts += 1
                searched[lo : hi + 1] = True
                # the square searched: the reach to the closest keyframe by the least variance
                variance = self._least_variance(poses, new, path)
                sigma = math.sqrt(float(variance[closest]))
                square_reach = min(
                    float(reach[closest]), self.p.loop_search_maximum_distance + self.p.loop_search_path_sigmas * sigma
                )
                window = SearchWindow(
                    min(self.p.loop_search_maximum_dimension, 2 * square_reach + 2.0),
                    self.p.coarse_search_angle_offset,
                    self.p.coarse_angle_resolution,
                )
                chain = list(range(lo, hi + 1))
                loops = self.counts.loops
                least = self.p.loop_match_minimum_response_fine
                shift = self._try_closure(new, chain, closest, poses[new], window, least)
                if shift is not None:
                    if self.counts.loops > loops:  # how far the match put the keyframe from its estimate, in sigmas
                        self._drift_ratios.append(shift / max(sigma, 1e-9))
                    return
        if self.p.loop_search_global:
            self._global_search(new, poses, d, full, searched, path, variance)

    def _submap(self, lo: int, hi: int) -> bool:
        """Whether keyframes ``lo``..``hi`` are enough of a chain to match a loop against: at least
        ``loop_match_minimum_chain_size`` of them, or as much travel as that many keyframes made every
        ``minimum_travel_distance`` would span when that is positive (a log whose scans lie farther apart has
        fewer keyframes along the same stretch, and a corridor it crosses would never make a chain)."""
        least = self.p.loop_match_minimum_chain_size
        need = (least - 1) * self.p.minimum_travel_distance
        return hi - lo + 1 >= least or (need > 0 and self._travel[hi] - self._travel[lo] >= need)

    def _least_variance(self, poses: np.ndarray, new: int, path: np.ndarray) -> np.ndarray:
        """Per keyframe before ``len(path)``: the smaller of two bounds of the same uncertainty of the new keyframe's
        position relative to it, the chain's (``path``, from ``_path_variance``) and the route's through the closures
        kept (``_route_variance``): a chain with a closure across it is known no worse than by either."""
        routes = self._route_variance(poses, new)
        return path if routes is None else np.minimum(path, routes[: len(path)])

    def _global_search(
        self,
        new: int,
        poses: np.ndarray,
        d: np.ndarray,
        full: np.ndarray,
        searched: np.ndarray,
        path: np.ndarray,
        variance: np.ndarray | None,
    ) -> None:
        """``loop_search_global``, once per ``loop_search_maximum_distance`` of travel at most: the keyframes older
        than the running buffer that the square search did not cover and whose uncertainty reaches past half of
        ``loop_search_maximum_dimension`` to the new keyframe -- ``loop_search_maximum_distance`` plus
        ``loop_search_path_sigmas`` standard deviations of ``_least_variance``, scaled by ``_drift_scale`` -- are
        looked through for the one whose place signature is most like the new keyframe's; the stretch of them
        around it (``GLOBAL_STRETCH`` either side, a chain ``_submap`` takes) is searched for the
        running buffer's surfaces (``GLOBAL_POINTS`` at most) in a square over the stretch's keyframes and
        ``loop_search_maximum_distance`` around them (``loop_search_space_dimension`` at least; on a grid as much
        coarser as it is wider), at the yaws of ``_global_turn``, with the loop's checks, at least
        ``loop_match_minimum_response_global`` and a shift from the estimate within that reach of the keyframe
        the closure joins."""
        cap = self.p.loop_search_maximum_dimension / 2
        scale = self._drift_scale()
        if not (full > cap).any() or scale == 0.0 or self._since_global < self.p.loop_search_maximum_distance:
            return
        if variance is None:
            variance = self._least_variance(poses, new, path)
        scaled = self.p.loop_search_maximum_distance + self.p.loop_search_path_sigmas * scale * np.sqrt(variance)
        candidate = (scaled > cap) & (d <= scaled) & ~searched
        if not candidate.any():
            return
        signatures = self._signatures.view()
        index = np.flatnonzero(candidate)
        best = int(index[int(np.argmin(np.abs(signatures[index] - signatures[new]).sum(axis=1)))])
        lo, hi = _run_around(candidate, best, GLOBAL_STRETCH)
        if not self._submap(lo, hi):
            return
        self.counts.global_searches += 1
        self._since_global = 0.0
        xy = poses[lo : hi + 1, :2]
        low, high = xy.min(axis=0), xy.max(axis=0)
        side = max(
            float(np.max(high - low)) + 2 * self.p.loop_search_maximum_distance, self.p.loop_search_space_dimension
        )
        centre = np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, poses[new, 2]])
        window = SearchWindow(side, self._global_turn(lo, new), self.p.coarse_angle_resolution)
        least = max(self.p.loop_match_minimum_response_fine, self.p.loop_match_minimum_response_global)
        self._try_closure(new, list(range(lo, hi + 1)), None, centre, window, least, self._surroundings(new), scaled)

    def _surroundings(self, new: int) -> np.ndarray:
        """The running buffer's surfaces in keyframe ``new``'s frame (``GLOBAL_POINTS`` at most, evenly spread): a
        few metres of the building, far more telling than one scan (a room or a stretch of corridor alike to the
        new scan is common; one alike with the rooms and corridors around it, rare)."""
        local = transform_points(_xyt(self._pose(new).inverse()), self._buffer_points(self._pose(new)))
        if len(local) > GLOBAL_POINTS:
            local = local[np.linspace(0, len(local) - 1, GLOBAL_POINTS).astype(np.int64)]
        return local

    def _far(self, shift: float, spread: float) -> bool:
        """Whether a square-search closure moving its keyframe ``shift`` m from its estimate, its search's spread
        ``spread`` (m^2), needs the running buffer's consent (``_confirmed``): beyond ``loop_search_maximum_distance``,
        or beyond half of it with a look-alike in the square (``LOOK_ALIKE_SPREAD``: a corridor's scan that matches
        a stretch two metres along)."""
        reach = self.p.loop_search_maximum_distance
        return shift > reach or (shift > reach / 2 and spread > LOOK_ALIKE_SPREAD)

    def _confirmed(self, reference: np.ndarray, new: int, pose: np.ndarray) -> bool:
        """Whether the running buffer's surfaces (``_surroundings``), matched against ``reference`` in a
        ``WIDE_REFINE`` square and yaw around ``pose`` (where a match put keyframe ``new``), reach
        ``loop_match_minimum_response_global``: the bar of a closure the global search finds, for a square-search
        closure that moves the keyframe far from its estimate (``_far``; a stretch of corridor one scan finds
        alike metres along is seldom alike with the few metres before it)."""
        window = SearchWindow(WIDE_REFINE[0], WIDE_REFINE[1], self.p.coarse_angle_resolution)
        least = self.p.loop_match_minimum_response_global
        return self.matcher.match(reference, self._surroundings(new), pose, window, least) is not None

    def _drift_scale(self) -> float:
        """How the path's uncertainty (``_path_variance``, ``_route_variance``: from the matches' covariances)
        compares with the drift the closures found: the largest shift of a keyframe by a closure the square
        search kept, in standard deviations of that uncertainty, once ``GLOBAL_CALIBRATION`` are in (1 before:
        the uncertainty as it stands). The matches' covariances are bounds, and a building's long corridors
        repeat: a search as wide as the bounds allow meets look-alike places that no drift of this log could
        have put the robot in."""
        if len(self._drift_ratios) < GLOBAL_CALIBRATION:
            return 1.0
        return min(1.0, max(self._drift_ratios))

    def _global_turn(self, first: int, new: int) -> float:
        """The yaw the global search turns either way: ``loop_search_path_sigmas`` standard deviations of the
        heading's uncertainty along the chain from keyframe ``first`` to ``new`` (at least
        ``coarse_search_angle_offset``, at most half a turn). A building's look-alike places are often each
        other turned a quarter or a half: a search at every yaw would meet them."""
        variance = float(np.sum(self._chain_cov.view()[first + 1 : new + 1, 2, 2]))
        wide = self.p.loop_search_path_sigmas * math.sqrt(variance)
        return min(math.pi, max(self.p.coarse_search_angle_offset, wide))

    def _try_closure(
        self,
        new: int,
        chain: list[int],
        anchor: int | None,
        prediction: np.ndarray,
        window: SearchWindow,
        least: float,
        points: np.ndarray | None = None,
        reach: np.ndarray | None = None,
    ) -> float | None:
        """The new keyframe's loop search against ``chain`` (``_loop_search``, of ``points`` in its frame: its
        scan's when None) and, for a match of at least ``least`` that pins the scan, that no other place in the
        square matches as well (a scan's own match failing either: the running buffer's surfaces,
        ``_surroundings``, in the same square instead, at least ``loop_match_minimum_response_global``),
        (``reach`` given, per keyframe) that moves the new keyframe from its estimate by no more than the reach
        of the keyframe it joins and (a match of the scan alone moving it far: ``_far``) that the running buffer
        confirms (``_confirmed``), a loop edge from ``anchor`` (the chain's keyframe nearest the match when None),
        kept if the optimised graph agrees with it (``loop_match_maximum_chi2``). When an edge was added, whether
        kept or taken back (either way the next search waits ``loop_search_maximum_distance``), how far the match
        put the new keyframe from its estimate (m); else None."""
        confirm = points is None  # a match of the new scan alone, confirmed by the buffer when it moves far
        points = self.keyframes[new].points if points is None else points
        reference = self._points_of(chain)
        searched = self._loop_search(reference, points, prediction, window)
        if searched is None:
            return None
        if searched[0].response < least:
            return None
        checked = self._unambiguous(searched)
        by_buffer = False
        if checked is None and confirm:
            # the scan alone leaves the place open: the running buffer's surfaces, a few metres of the building, may
            # not; their match stands in for the scan's at the global search's bar
            wider = self._loop_search(reference, self._surroundings(new), prediction, window)
            if wider is not None and wider[0].response >= max(least, self.p.loop_match_minimum_response_global):
                checked = self._unambiguous(wider)
                by_buffer = checked is not None
        if checked is None:
            self.counts.loops_ambiguous += 1
            return None
        match, cov, ambiguity = checked
        poses = self.graph.poses()
        if anchor is None:
            anchor = chain[int(np.argmin(np.linalg.norm(poses[chain, :2] - match.pose[:2], axis=1)))]
        shift = float(np.hypot(*(match.pose[:2] - poses[new, :2])))
        if reach is not None and shift > reach[anchor]:
            self.counts.loops_inconsistent += 1  # farther from the estimate than the path's uncertainty reaches
            return None
        if (
            confirm
            and not by_buffer
            and self._far(shift, ambiguity)
            and not self._confirmed(reference, new, match.pose)
        ):
            self.counts.loops_inconsistent += 1  # the metres before the scan disagree with the place it found
            return None
        rel = _pose2(poses[anchor]).between(_pose2(match.pose))
        # the global search's tries are the ones given a reach
        closed_by: ClosedBy = "global" if reach is not None else "buffer" if by_buffer else "scan"
        self.graph.add_edge(
            anchor,
            new,
            _xyt(rel),
            _edge_covariance(cov, match.pose[2]),
            "loop",
            response=match.response,
            kernel=self.p.loop_kernel,
            kernel_k=self.p.loop_kernel_k,
            closed_by=closed_by,
        )
        self.graph.optimize()
        # the next keyframes would meet the same chain: wait as after a closure (each try is an optimisation)
        self._since_loop = 0.0
        if self.graph.edge_chi2() > self.p.loop_match_maximum_chi2:
            # the rest of the graph disagrees with the closure: a false match, taken back
            self.graph.remove_last_edge()
            self.counts.loops_inconsistent += 1
            return shift
        self.counts.loops += 1
        self.counts.loops_global += closed_by == "global"
        self.counts.loops_buffer += closed_by == "buffer"
        self._loop_edges.append((anchor, new, cov[0, 0] + cov[1, 1], cov[2, 2]))
        return shift

    def _unambiguous(
        self, searched: tuple[MatchResult, Callable[[], float]]
    ) -> tuple[MatchResult, np.ndarray, float] | None:
        """A loop search's match, its covariance and its spread, when the match pins the scan (``_pins``: a
        corridor's axis does not) and no other place in the square matches as well (``loop_match_maximum_spread``);
        None otherwise."""
        match, spread = searched
        cov = self._match_covariance(match, self.p.loop_sigmas)
        if not self._pins(cov):
            return None
        ambiguity = spread()
        if ambiguity > self.p.loop_match_maximum_spread:
            return None
        return match, cov, ambiguity

    def _loop_search(
        self, reference: np.ndarray, points: np.ndarray, prediction: np.ndarray, window: SearchWindow
    ) -> tuple[MatchResult, Callable[[], float]] | None:
        """The scan's loop match against a chain's points in ``window`` around ``prediction``, and a function
        giving the search's spread (``ScanMatcher.spread``, computed only if asked). A window wider than
        ``loop_search_space_dimension`` is searched on a correlation grid coarser in proportion, for a pose
        at ``loop_match_minimum_response_coarse`` at least, and the scan then matched at full resolution in a
        1 m square around it (``WIDE_REFINE``; eight coarse cells where they are larger). None when no pose
        reaches ``loop_match_minimum_response_fine``."""
        wide = window.linear > self.p.loop_search_space_dimension
        matcher = self.matcher
        if wide:
            coarse = self.p.correlation_search_space_resolution * window.linear / self.p.loop_search_space_dimension
            # a likelihood no sharper than the grid's cells
            matcher = ScanMatcher(coarse, max(self.p.correlation_search_space_smear_deviation, coarse))
        grid = matcher.grid_around(reference, points, prediction, window)
        if grid is None:
            return None
        least = self.p.loop_match_minimum_response_coarse if wide else self.p.loop_match_minimum_response_fine
        found = matcher.match_on(grid, points, prediction, window, least)
        if found is None:
            return None
        match: MatchResult | None = found
        if wide:
            # the square covers the coarse grid's cells around its pose (eight of them past a 40 m search)
            side = max(WIDE_REFINE[0], 8 * matcher.res)
            refine = SearchWindow(side, WIDE_REFINE[1], self.p.coarse_angle_resolution / 2)
            match = self.matcher.match(reference, points, found.pose, refine, self.p.loop_match_minimum_response_fine)
        if match is None:
            return None
        return match, lambda: matcher.spread(grid, points, prediction, window, found.response)

    def _path_variance(self, poses: np.ndarray, new: int) -> np.ndarray:
        """Per keyframe i <= new: the variance, in its worst direction, of keyframe ``new``'s position
        relative to keyframe i along the chain of sequential edges between them: the sum over the edges k
        of their translation covariance (rotated into the map frame) and their yaw variance times the
        lever arm from keyframe k to ``new`` (a heading error at k swings everything after it about k)."""
        cov = self._chain_cov.view()[: new + 1]  # edge k: keyframe k - 1 -> k, in k's frame
        theta = poses[: new + 1, 2]  # the heading of edge k's target
        c, s = np.cos(theta), np.sin(theta)
        rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (n, 2, 2)
        trans = rot @ cov[:, :2, :2] @ np.swapaxes(rot, 1, 2)
        yaw = cov[:, 2, 2]
        p = poses[: new + 1, :2]
        terms = np.concatenate(
            [
                trans.reshape(-1, 4),
                yaw[:, None],
                yaw[:, None] * p,
                (yaw[:, None, None] * p[:, :, None] * p[:, None, :]).reshape(-1, 4),
            ],
            axis=1,
        )
        total = np.cumsum(terms, axis=0)
        after = total[-1] - total  # sums over the edges k in (i, new]
        a = after[:, 0:4].reshape(-1, 2, 2)
        sy, sp, spp = after[:, 4], after[:, 5:7], after[:, 7:11].reshape(-1, 2, 2)
        pn = p[-1]
        # sum_k yaw_k (pn - p_k)(pn - p_k)^T, then turned a quarter (the lever arm's perpendicular)
        b = (
            sy[:, None, None] * np.outer(pn, pn)
            - pn[None, :, None] * sp[:, None, :]
            - sp[:, :, None] * pn[None, None, :]
            + spp
        )
        m = a + np.stack([np.stack([b[:, 1, 1], -b[:, 1, 0]], -1), np.stack([-b[:, 0, 1], b[:, 0, 0]], -1)], -2)
        half = 0.5 * (m[:, 0, 0] + m[:, 1, 1])
        return half + np.sqrt(np.maximum(0.25 * (m[:, 0, 0] - m[:, 1, 1]) ** 2 + m[:, 0, 1] * m[:, 1, 0], 0.0))

    def _route_variance(self, poses: np.ndarray, new: int) -> np.ndarray | None:
        """Per keyframe i <= new: the variance of keyframe ``new``'s position relative to keyframe i along the
        graph's route of least variance, through the loop closures kept (None before the first). Each edge adds the
        trace of its translation covariance and its yaw variance times the square of the lever arm from the edge's
        target to ``new`` (an edge's noise is in its target's frame: a yaw error there swings ``new`` about the target,
        whichever way the route crosses the edge): ``_path_variance``'s sum along the chain, with each matrix
        taken by its trace (an upper bound of its worst direction), so that the sums add along any route
        (scipy's Dijkstra)."""
        if not len(self._loop_edges):
            return None
        n = new + 1
        cov = self._chain_cov.view()[:n]
        lever = np.sum(np.square(poses[:n, :2] - poses[new, :2]), axis=1)
        loops = self._loop_edges.view()
        k = np.arange(1, n)  # sequential edge k: keyframe k - 1 -> k
        a, b = loops[:, 0].astype(np.int64), loops[:, 1].astype(np.int64)  # loop edge: a -> b
        src, dst = np.concatenate([k - 1, a]), np.concatenate([k, b])
        weight = np.concatenate(
            [cov[k, 0, 0] + cov[k, 1, 1] + cov[k, 2, 2] * lever[k], loops[:, 2] + loops[:, 3] * lever[b]]
        )
        # one edge per pair, the least (two closures between the same keyframes; csr_matrix would add them)
        order = np.lexsort((weight, dst, src))
        src, dst, weight = src[order], dst[order], weight[order]
        first = np.ones(len(src), dtype=bool)
        first[1:] = (src[1:] != src[:-1]) | (dst[1:] != dst[:-1])
        graph = csr_matrix((weight[first] + 1e-12, (src[first], dst[first])), shape=(n, n))  # no zero: no edge
        return dijkstra(graph, directed=False, indices=new)

    # ------------------------------------------------------------ results
    def _pose(self, i: int) -> gtsam.Pose2:
        return _pose2(self.graph.pose(i))

    def _pose_xy(self, i: int) -> np.ndarray:
        return self.graph.pose(i)[:2]

    @property
    def map_to_odom(self) -> np.ndarray:
        """4x4 map <- odom implied by the last keyframe (the identity before the first)."""
        if not self.keyframes:
            return np.eye(4)
        last = self.keyframes[-1]
        m = self._pose(last.index).compose(last.log_odom.inverse())
        return planar_matrix(m.x(), m.y(), m.theta())

    def trajectory(self) -> tuple[list[int], np.ndarray]:
        """Stamps and (n, 3) map poses of every scan: its keyframe's final pose composed with its pose relative
        to the keyframe (the odometry since it, or since the last scan matched between keyframes)."""
        poses = [self._pose(k) for k in range(len(self.keyframes))]
        out = np.array([_xyt(poses[k].compose(rel)) for _, k, rel in self._scans]).reshape(-1, 3)
        return [t for t, _, _ in self._scans], out

    def grid(self, final: bool = True) -> OccupancyGrid2D:
        """The occupancy grid of every keyframe's scan at its current pose (see the module docstring).

        ``final=False`` (the maps published while the log plays) redraws the grid after an optimisation
        moved its keyframes only once the keyframes added since the last redraw reach a quarter of all
        (new keyframes are drawn at once): the total work of the redraws stays linear in the travel
        however many loops close. ``final=True`` redraws whenever a keyframe moved."""
        poses = self.graph.poses()
        done = len(self._grid_poses)
        if done:
            moved = poses[:done] - self._grid_poses
            reach = min(self.p.max_laser_range, self._range_max[done - 1])
            shift = np.hypot(moved[:, 0], moved[:, 1]) + reach * np.abs(angle_diff(moved[:, 2], 0.0))
            due = final or len(self.keyframes) - self._grid_drawn >= 0.25 * len(self.keyframes)
            if float(shift.max()) > self.grid_params.resolution and due:
                self._grid = OccupancyGrid2D(self.grid_params)
                self._grid_drawn = len(self.keyframes)
                self.counts.off_map.clear()  # counted again as the keyframes are drawn again
                done = 0
        for k in self.keyframes[done:]:
            x, y, yaw = poses[k.index]
            s = k.scan
            try:
                self._grid.insert_scan(planar_matrix(x, y, yaw) @ s.mount, s.angles, s.ranges, s.range_min, s.range_max)
            except GridTooLarge:  # the grid is as it was: the keyframe stays out of the map, counted
                self.counts.off_map.add(k.index)
        self._grid_poses = np.concatenate([self._grid_poses[:done], poses[done:]])
        return self._grid
