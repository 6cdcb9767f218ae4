"""NavFn as Nav2's ``nav2_navfn_planner`` computes it: cost conversion, potential, gradient path.

Steps (reference: nav2.md §2):
1. costmap costs c -> NavFn costs: c < 253 -> 50 + 0.8 c (int, capped 253); 253, 254 -> 254 (blocked);
   255 -> 253 if allow_unknown else 254; the outer border -> 254; the robot's own cell -> free.
2. the potential is seeded at the robot cell (0) and grown until the goal cell has one (Dijkstra;
   A* adds hypot(cell - goal) * 50 to the priority), with NavFn's quadratic two-neighbour update and its
   priority buffers (threshold raised by 100 each time the current band empties).
3. tolerance: the reachable point within goal +- tolerance (steps of one cell) closest to the goal.
4. the path runs from the goal down the bilinearly interpolated, normalised gradient in 0.5-cell
   steps, jumping to the lowest of the 8 neighbours where the gradient is undefined or oscillates,
   until the potential is below 50; at most 4 * max(nx, ny) steps. It is then reversed (robot -> goal).
5. NavFn's own cell convention: world -> cell = round((w - o) / res), cell -> world = o + m * res.

Two ways to grow the potential give the same field up to the order of updates inside one band:
``potential_exact`` updates cell by cell exactly in NavFn's order (pure Python, for small grids and
as the reference), ``potential_wavefront`` updates each cycle's cells together with numpy (default).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.nav2.planners.base import (
    PlanningCostmap,
    PlanningError,
    PlanResult,
    Pose2D,
    costmap_extent,
    path_cost,
    path_length,
    tolerance_hint,
)
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param

POT_HIGH = 1.0e10
COST_OBS = 254
COST_NEUTRAL = 50
COST_FACTOR = 0.8
PRI_INC = 2 * COST_NEUTRAL
INVSQRT2 = 0.707106781
PATH_STEP = 0.5


@dataclass(frozen=True)
class NavfnParams(PluginParams):
    """``nav2_navfn_planner::NavfnPlanner`` parameters."""

    plugin: str = "nav2_navfn_planner::NavfnPlanner"
    tolerance: float = param(0.5, ge=0.0)
    use_astar: bool = False
    allow_unknown: bool = True
    use_final_approach_orientation: bool = False


def navfn_costs(costs: np.ndarray, allow_unknown: bool = True) -> np.ndarray:
    """NavFn's cost array (int16, same shape) from costmap costs (uint8), border set to 254."""
    c = np.asarray(costs, dtype=np.int32)
    out = np.full(c.shape, COST_OBS, dtype=np.int16)
    low = c < 253
    out[low] = np.minimum((COST_NEUTRAL + COST_FACTOR * c[low]).astype(np.int32), COST_OBS - 1)
    if allow_unknown:
        out[c == 255] = COST_OBS - 1
    out[0, :] = out[-1, :] = COST_OBS
    out[:, 0] = out[:, -1] = COST_OBS
    return out


def potential_exact(
    cost: np.ndarray, seed: tuple[int, int], target: tuple[int, int], use_astar: bool = False, cycles: int | None = None
) -> np.ndarray:
    """NavFn's propagation, one cell at a time in NavFn's order. cost: navfn_costs (ny, nx)."""
    ny, nx = cost.shape
    ns = nx * ny
    c = cost.ravel().tolist()
    pot = [POT_HIGH] * ns
    pending = bytearray(ns)
    s = seed[1] * nx + seed[0]
    t = target[1] * nx + target[0]
    tx, ty = target
    cycles = cycles or max(ns // 20, nx + ny)
    cur: list[int] = []
    nxt: list[int] = []
    over: list[int] = []

    def push(buf: list[int], n: int) -> None:
        if 0 <= n < ns and not pending[n] and c[n] < COST_OBS:
            buf.append(n)
            pending[n] = 1

    pot[s] = 0.0
    for n in (s + 1, s - 1, s - nx, s + nx):
        push(cur, n)
    cur_t = float(COST_OBS)
    if use_astar:
        cur_t += math.hypot(seed[0] - tx, seed[1] - ty) * COST_NEUTRAL
    for _ in range(cycles):
        if not cur and not nxt:
            break
        for n in cur:
            pending[n] = 0
        for n in cur:
            hf = c[n]
            if hf >= COST_OBS:
                continue
            left, right, up, down = pot[n - 1], pot[n + 1], pot[n - nx], pot[n + nx]
            tc = left if left < right else right
            ta = up if up < down else down
            dc = tc - ta
            if dc < 0:
                dc = -dc
                ta = tc
            if dc >= hf:
                p = ta + hf
            else:
                r = dc / hf
                p = ta + hf * (-0.2301 * r * r + 0.5307 * r + 0.7040)
            p = float(np.float32(p))
            if p < pot[n]:
                pot[n] = p
                pri = p
                if use_astar:
                    pri = p + math.hypot(n % nx - tx, n // nx - ty) * COST_NEUTRAL
                buf = nxt if pri < cur_t else over
                for m in (n - 1, n + 1, n - nx, n + nx):
                    if pot[m] > pri + INVSQRT2 * c[m]:
                        push(buf, m)
        cur, nxt = nxt, []
        if not cur:
            cur_t += PRI_INC
            cur, over = over, []
        if pot[t] < POT_HIGH:
            break
    return np.asarray(pot, dtype=np.float32).reshape(ny, nx)


def potential_wavefront(
    cost: np.ndarray, seed: tuple[int, int], target: tuple[int, int], use_astar: bool = False, cycles: int | None = None
) -> np.ndarray:
    """NavFn's propagation with each cycle's cells updated together (numpy).

    The same cycles, bands and queueing rule as ``potential_exact``. Inside a cycle the cells are
    updated red-black: cells of one parity (x + y) have no 4-neighbour of the same parity, so all
    cells of one parity are updated together, then those of the other with the new values, as
    NavFn's in-order updates use the newest values.
    """
    ny, nx = cost.shape
    ns = nx * ny
    flat = cost.ravel()
    c = flat.astype(np.float32)
    blocked = flat >= COST_OBS
    # the potential lives in a padded buffer, so each 4-neighbour is a view (no index arithmetic)
    pad = nx + 1
    buf = np.full(ns + 2 * pad, POT_HIGH, dtype=np.float32)
    pot = buf[pad : pad + ns]
    left, right = buf[pad - 1 : pad - 1 + ns], buf[pad + 1 : pad + 1 + ns]
    up, down = buf[pad - nx : pad - nx + ns], buf[pad + nx : pad + nx + ns]
    # queueing threshold 0.7071 * cost, +inf where blocked or already queued: one comparison tests all three
    thr0 = np.float32(INVSQRT2) * c
    thr0[blocked] = np.inf
    thr = thr0.copy()
    s = seed[1] * nx + seed[0]
    t = target[1] * nx + target[0]
    tx, ty = target
    cycles = cycles or max(ns // 20, nx + ny)
    odd = ((np.arange(ny)[:, None] + np.arange(nx)[None, :]) & 1).astype(bool).ravel()
    stamp = np.zeros(ns, dtype=np.intp)  # duplicate removal: the last position written for a cell wins
    off = np.array([-1, 1, -nx, nx], dtype=np.intp)
    cap = 4 * (nx + ny)
    positions = np.arange(cap, dtype=np.intp)
    offsets = np.tile(off, cap // 4)
    pot[s] = 0.0
    cur = s + off
    cur = cur[(cur >= 0) & (cur < ns)]
    cur = cur[~blocked[cur]]
    thr[cur] = np.inf
    waiting: list[np.ndarray] = []  # cells queued from above the threshold: the next band
    cur_t = float(COST_OBS)
    if use_astar:
        cur_t += math.hypot(seed[0] - tx, seed[1] - ty) * COST_NEUTRAL
        xs = np.arange(nx, dtype=np.float32)[None, :]
        ys = np.arange(ny, dtype=np.float32)[:, None]
        h = (np.hypot(xs - tx, ys - ty) * COST_NEUTRAL).ravel()  # float32, as the priority is added
    # 0-d float32 arrays: the same arithmetic as Python floats on float32 arrays, with less overhead per call
    qa, qb, qc, one, inf = (np.array(v, dtype=np.float32) for v in (-0.2301, 0.5307, 0.7040, 1.0, np.inf))
    threshold = np.array(cur_t, dtype=np.float32)
    for _ in range(cycles):
        if len(cur) == 0:
            break
        thr[cur] = thr0[cur]  # no longer queued
        o = odd[cur]
        parts = []
        for half in (cur[~o], cur[o]):
            # NavFn's update: ta, tc the lower neighbour on each axis, hf the cell's cost
            tc = np.minimum(left[half], right[half])
            ta = np.minimum(up[half], down[half])
            lo = np.minimum(ta, tc)
            dc = np.abs(ta - tc)
            hf = c[half]
            r = dc / hf
            p = qa * r
            p += qb
            p *= r
            p += qc
            p[dc >= hf] = one
            p *= hf
            p += lo
            better = p < pot[half]
            if np.count_nonzero(better) < len(half):
                half, p = half[better], p[better]
            pot[half] = p
            parts.append((half, p))
        cells = np.concatenate((parts[0][0], parts[1][0]))
        pri = np.concatenate((parts[0][1], parts[1][1]))
        if use_astar:
            pri = pri + h[cells]
        # queue the neighbours whose potential is above pri + 0.7071 * their cost
        n4 = 4 * len(cells)
        if 2 * n4 > cap:
            cap = 2 * n4
            positions = np.arange(cap, dtype=np.intp)
            offsets = np.tile(off, cap // 4)
        nb = cells.repeat(4) + offsets[:n4]
        pri4 = pri.repeat(4)
        ok = np.flatnonzero(pot[nb] > pri4 + thr[nb])
        cand = nb[ok]
        low = pri4[ok] < threshold
        nxt = cand[low]
        n = len(nxt)
        stamp[nxt] = positions[:n]
        if n < len(cand):  # neighbours of cells above the threshold wait for the next band
            over = cand[~low]
            m = len(over)
            stamp[over] = positions[n : n + m]
            stamp[nxt] = positions[:n]  # a cell queued from both sides stays in this band
            over = over[stamp[over] == positions[n : n + m]]
            thr[over] = inf
            waiting.append(over)
        cur = nxt[stamp[nxt] == positions[:n]]
        thr[cur] = inf
        if len(cur) == 0:  # the band is done: raise the threshold, the waiting cells are next
            cur_t += PRI_INC
            threshold = np.array(cur_t, dtype=np.float32)
            cur = np.concatenate(waiting) if waiting else np.empty(0, dtype=np.intp)
            waiting = []
        if pot[t] < POT_HIGH:
            break
    return pot.reshape(ny, nx)


def extract_path(
    pot: np.ndarray, start: tuple[int, int], goal: tuple[int, int], max_cycles: int
) -> list[tuple[float, float]]:
    """NavFn's gradient descent from ``start`` (the world goal) to ``goal`` (the robot), in cells.

    Returns [] when it fails. Points are (x, y) in NavFn cell coordinates.
    """
    ny, nx = pot.shape
    ns = nx * ny
    p = np.ascontiguousarray(pot).ravel().data  # a memoryview: Python floats on access, no copy of the grid
    cache: dict[int, tuple[float, float]] = {}

    def grad(n: int) -> tuple[float, float]:
        """NavFn's normalised gradient at a cell ((0, 0) on the border rows or where it vanishes)."""
        g = cache.get(n)
        if g is not None:
            return g
        g = (0.0, 0.0)
        if not (n < nx or n > ns - nx):
            cv = p[n]
            dx = dy = 0.0
            if cv >= POT_HIGH:
                if p[n - 1] < POT_HIGH:
                    dx = -COST_OBS
                elif p[n + 1] < POT_HIGH:
                    dx = COST_OBS
                if p[n - nx] < POT_HIGH:
                    dy = -COST_OBS
                elif p[n + nx] < POT_HIGH:
                    dy = COST_OBS
            else:
                pl, pr, pu, pd = p[n - 1], p[n + 1], p[n - nx], p[n + nx]
                if pl < POT_HIGH:
                    dx += pl - cv
                if pr < POT_HIGH:
                    dx += cv - pr
                if pu < POT_HIGH:
                    dy += pu - cv
                if pd < POT_HIGH:
                    dy += cv - pd
            norm = math.hypot(dx, dy)
            if norm > 0:
                g = (dx / norm, dy / norm)
        cache[n] = g
        return g

    stc = start[1] * nx + start[0]
    dx = dy = 0.0
    path: list[tuple[float, float]] = []
    for _ in range(max_cycles):
        nearest = max(0, min(ns - 1, stc + int(round(dx)) + nx * int(round(dy))))
        if p[nearest] < COST_NEUTRAL:
            path.append((float(goal[0]), float(goal[1])))
            return path
        if stc < nx or stc > ns - nx:
            return []
        path.append((stc % nx + dx, stc // nx + dy))
        up, dn = stc - nx, stc + nx
        if (len(path) > 2 and path[-1] == path[-3]) or max(
            p[stc], p[stc + 1], p[stc - 1], p[dn], p[dn + 1], p[dn - 1], p[up], p[up + 1], p[up - 1]
        ) >= POT_HIGH:
            minc, minp = stc, p[stc]
            for k in (up - 1, up, up + 1, stc - 1, stc + 1, dn - 1, dn, dn + 1):
                if p[k] < minp:
                    minp, minc = p[k], k
            stc = minc
            dx = dy = 0.0
            if p[stc] >= POT_HIGH:
                return []
        else:
            g00x, g00y = grad(stc)
            g10x, g10y = grad(stc + 1)
            g01x, g01y = grad(dn)
            g11x, g11y = grad(dn + 1)
            x1 = (1.0 - dx) * g00x + dx * g10x
            x2 = (1.0 - dx) * g01x + dx * g11x
            x = (1.0 - dy) * x1 + dy * x2
            y1 = (1.0 - dx) * g00y + dx * g10y
            y2 = (1.0 - dx) * g01y + dx * g11y
            y = (1.0 - dy) * y1 + dy * y2
            if x == 0.0 and y == 0.0:
                return []
            ss = PATH_STEP / math.hypot(x, y)
            dx += x * ss
            dy += y * ss
            if dx > 1.0:
                stc += 1
                dx -= 1.0
            if dx < -1.0:
                stc -= 1
                dx += 1.0
            if dy > 1.0:
                stc += nx
                dy -= 1.0
            if dy < -1.0:
                stc -= nx
                dy += 1.0
    return []


class NavfnPlanner:
    """Plan on a costmap (anything with ``costs``, ``resolution``, ``origin_x``, ``origin_y``)."""

    def __init__(self, params: NavfnParams, potential: str = "wavefront") -> None:
        if potential not in ("wavefront", "exact"):
            raise NavlogError(f"NavFn potential must be 'wavefront' or 'exact', got {potential!r}")
        self.p = params
        self.potential = potential
        self.last_potential: np.ndarray | None = None

    # NavFn's cell convention (half a cell off the costmap's)
    @staticmethod
    def _to_cell(cm: PlanningCostmap, x: float, y: float) -> tuple[int, int] | None:
        if x < cm.origin_x or y < cm.origin_y:
            return None
        mx = int(round((x - cm.origin_x) / cm.resolution))
        my = int(round((y - cm.origin_y) / cm.resolution))
        ny, nx = cm.costs.shape
        if mx < nx and my < ny:
            return mx, my
        return None

    def plan(self, cm: PlanningCostmap, start: Pose2D, goal: Pose2D) -> PlanResult:
        t0 = time.perf_counter()
        res = cm.resolution
        ny, nx = cm.costs.shape
        sx = math.floor((start[0] - cm.origin_x) / res)
        sy = math.floor((start[1] - cm.origin_y) / res)
        if not (0 <= sx < nx and 0 <= sy < ny) or self._to_cell(cm, start[0], start[1]) is None:
            raise PlanningError(f"start ({start[0]:.2f}, {start[1]:.2f}) is outside the costmap {costmap_extent(cm)}")
        goal_cell = self._to_cell(cm, goal[0], goal[1])
        if goal_cell is None:
            raise PlanningError(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is outside the costmap {costmap_extent(cm)}")
        if not (cm.costs < 253).any() and not (self.p.allow_unknown and (cm.costs == 255).any()):
            raise PlanningError(
                "the costmap has no free cell"
                + ("" if self.p.allow_unknown else " (unknown cells are not allowed: allow_unknown false)")
            )
        gx0 = math.floor((goal[0] - cm.origin_x) / res)
        gy0 = math.floor((goal[1] - cm.origin_y) / res)
        if self.p.tolerance == 0.0 and 0 <= gx0 < nx and 0 <= gy0 < ny and cm.costs[gy0, gx0] == 254:
            raise PlanningError(
                f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is in a lethal cell (goal occupied) and "
                f"tolerance is 0{self._hint(cm, goal)}"
            )
        costs = cm.costs.copy()
        costs[sy, sx] = 0  # the robot's own cell is free
        cost = navfn_costs(costs, self.p.allow_unknown)
        robot = self._to_cell(cm, start[0], start[1])
        assert robot is not None
        if robot == goal_cell:
            pose = (goal[0], goal[1], start[2] if self.p.use_final_approach_orientation else goal[2])
            return PlanResult(np.array([pose]), 0.0, 0.0, time.perf_counter() - t0, pose, "navfn")
        grow = potential_exact if self.potential == "exact" else potential_wavefront
        pot = grow(cost, robot, goal_cell, use_astar=self.p.use_astar)
        self.last_potential = pot
        best = None
        best_d = math.inf
        tol = self.p.tolerance
        py = goal[1] - tol
        while py <= goal[1] + tol + 1e-12:
            px = goal[0] - tol
            while px <= goal[0] + tol + 1e-12:
                cell = self._to_cell(cm, px, py)
                if cell is not None and pot[cell[1], cell[0]] < POT_HIGH:
                    d = (px - goal[0]) ** 2 + (py - goal[1]) ** 2
                    if d < best_d:
                        best_d, best = d, (px, py)
                px += res
            py += res
        if best is None:
            raise PlanningError(
                f"no path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, {goal[1]:.2f}) "
                f"within tolerance {tol} m{self._hint(cm, goal)}"
            )
        bcell = self._to_cell(cm, best[0], best[1])
        assert bcell is not None  # best is a cell with a potential
        cells = extract_path(pot, bcell, robot, 4 * max(nx, ny))
        if not cells:
            raise PlanningError(
                "a potential reaches the goal but the gradient path failed (as NavFn can, "
                "navigation2#4655); try use_astar or the smac2d planner"
            )
        xy = np.array([(cm.origin_x + x * res, cm.origin_y + y * res) for x, y in reversed(cells)])
        goal_pose = (best[0], best[1], goal[2])
        # smoothApproachToGoal: replace the last point if it is farther from the one before than the goal
        if (
            len(xy) >= 2
            and np.sum((xy[-1] - xy[-2]) ** 2) > (goal_pose[0] - xy[-2][0]) ** 2 + (goal_pose[1] - xy[-2][1]) ** 2
        ):
            xy[-1] = goal_pose[:2]
        else:
            xy = np.vstack([xy, goal_pose[:2]])
        poses = np.column_stack([xy, np.zeros(len(xy))])
        poses[-1, 2] = goal[2]
        if self.p.use_final_approach_orientation:
            if len(poses) == 1:
                poses[-1, 2] = start[2]
            else:
                before = poses[-2]
                # NavFn often ends with two equal poses (the goal cell and the goal): look one further back
                if abs(poses[-1, 0] - before[0]) < 1e-4 and abs(poses[-1, 1] - before[1]) < 1e-4 and len(poses) > 2:
                    before = poses[-3]
                poses[-1, 2] = math.atan2(poses[-1, 1] - before[1], poses[-1, 0] - before[0])
        notes = []
        if best_d > 1e-12:
            notes.append(
                f"goal unreachable; tolerance moved it by {math.sqrt(best_d):.3f} m to ({best[0]:.3f}, {best[1]:.3f})"
            )
        length = path_length(poses)
        pcost = path_cost(poses, cost, res, (cm.origin_x - 0.5 * res, cm.origin_y - 0.5 * res), COST_NEUTRAL)
        return PlanResult(poses, length, pcost, time.perf_counter() - t0, (best[0], best[1], goal[2]), "navfn", notes)

    def _hint(self, cm: PlanningCostmap, goal: Pose2D) -> str:
        return tolerance_hint(cm, goal, self.p.allow_unknown)
