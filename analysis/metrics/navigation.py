"""Navigation metrics of a log: per goal its result, time, path, clearance, collisions, recoveries, speed and jerk.

Pure computation on what ``report`` reads from a log:

- the navigator's events (``/navlog/events``): ``goal_accepted`` starts a goal (detail: its name),
  ``goal_succeeded`` / ``goal_failed`` end it (value: Nav2's error code, detail: the message),
  ``recovery_started`` counts a recovery; the simulator's ``collision`` events count contacts;
- the ground-truth trajectory: the path length travelled and the speed;
- the commands the robot drove on (``/cmd_vel``): acceleration and jerk of the linear command
  (finite differences at the commands' own stamps), the smoothness a Nav2 user tunes;
- a reference grid (``navlog world-map WORLD --margin 0``): the clearance of the robot's centre to
  the nearest occupied cell (its centre distance less half a cell, so a point on a cell's edge reads
  0), from a Euclidean distance transform.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.analysis.metrics.trajectory import Trajectory

Event = tuple[int, str, str, str, float]  # time ns, kind, source, detail, value


@dataclass
class GoalEpisode:
    """One goal from its acceptance to its end (``end_ns`` None: the log ended first)."""

    name: str
    start_ns: int
    end_ns: int | None = None
    status: str = "unfinished"  # succeeded | failed | unfinished
    code: int = 0
    message: str = ""
    recoveries: list[str] = field(default_factory=list)
    collisions: int = 0


def goal_episodes(events: list[Event]) -> tuple[list[GoalEpisode], int]:
    """The goals in the order they were accepted, and every collision (also those outside a goal)."""
    goals: list[GoalEpisode] = []
    collisions = 0
    active: GoalEpisode | None = None
    for t, kind, _source, detail, value in sorted(events, key=lambda e: e[0]):
        if kind == "goal_accepted":
            if active is not None and active.end_ns is None:  # pre-empted by a new goal
                active.end_ns, active.status, active.message = t, "failed", "pre-empted by a new goal"
            active = GoalEpisode(detail, t)
            goals.append(active)
        elif kind in ("goal_succeeded", "goal_failed") and active is not None and active.end_ns is None:
            active.end_ns = t
            active.status = "succeeded" if kind == "goal_succeeded" else "failed"
            active.code = int(value)
            active.message = detail
        elif kind == "recovery_started" and active is not None and active.end_ns is None:
            active.recoveries.append(detail)
        elif kind == "collision":
            collisions += 1
            if active is not None and active.end_ns is None:
                active.collisions += 1
    return goals, collisions


def clearance_field(occupied: np.ndarray, resolution: float) -> np.ndarray:
    """Per cell, the distance (m) from its centre to the nearest occupied cell's edge (0 on occupied cells)."""
    from scipy.ndimage import distance_transform_edt

    if not occupied.any():
        return np.full(occupied.shape, np.inf)
    d = distance_transform_edt(~occupied) * resolution
    return np.maximum(d - resolution / 2, 0.0)


def clearances(reference: Any, xy: np.ndarray, field_m: np.ndarray) -> np.ndarray:
    """Clearance (m) at points (N, 2) from a ``clearance_field`` of ``reference``; NaN outside its grid."""
    mx, my = reference.world_to_cell(xy[:, 0], xy[:, 1])
    mx, my = np.asarray(mx), np.asarray(my)
    inside = (mx >= 0) & (my >= 0) & (mx < reference.width) & (my < reference.height)
    out = np.full(len(xy), np.nan)
    out[inside] = field_m[my[inside], mx[inside]]
    return out


def _stats(values: np.ndarray) -> dict[str, float] | None:
    v = values[np.isfinite(values)]
    if not v.size:
        return None
    return {"mean": float(v.mean()), "max": float(v.max()), "rms": float(np.sqrt(np.mean(v**2)))}


def command_jerk(times_ns: np.ndarray, vx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration and jerk of the linear command by finite differences (repeated stamps dropped)."""
    if len(times_ns) < 3:
        return np.zeros(0), np.zeros(0)
    keep = np.concatenate([[True], np.diff(times_ns) > 0])
    t, v = times_ns[keep] / 1e9, vx[keep]
    if len(t) < 3:
        return np.zeros(0), np.zeros(0)
    acc = np.diff(v) / np.diff(t)
    tm = (t[1:] + t[:-1]) / 2
    jerk = np.diff(acc) / np.diff(tm)
    return acc, jerk


def navigation_metrics(
    events: list[Event],
    gt: Trajectory | None,
    commands: tuple[np.ndarray, np.ndarray] | None,
    reference: Any | None = None,
) -> dict[str, Any] | None:
    """The navigation section of ``navlog metrics`` (None when the log has no goal event).

    ``commands``: (times ns, vx) of what the robot drove on; ``reference``: an ``OccupancyMap`` of the
    true obstacles (occupied >= 65) for the clearance.
    """
    goals, collisions = goal_episodes(events)
    if not goals:
        return None
    field_m = None
    if reference is not None:
        field_m = clearance_field(np.asarray(reference.data) >= 65, reference.resolution)
    t_gt = gt.times_ns if gt is not None else np.zeros(0, dtype=np.int64)
    per_goal = []
    for g in goals:
        end = g.end_ns if g.end_ns is not None else (int(t_gt[-1]) if len(t_gt) else g.start_ns)
        row: dict[str, Any] = {
            "name": g.name,
            "status": g.status,
            "code": g.code,
            "message": g.message,
            "time_s": (end - g.start_ns) / 1e9,
            "recoveries": len(g.recoveries),
            "recovery_kinds": g.recoveries,
            "collisions": g.collisions,
        }
        if gt is not None:
            sel = (t_gt >= g.start_ns) & (t_gt <= end)
            xy = gt.positions[sel, :2]
            row["path_length_m"] = float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0
            if field_m is not None and len(xy):
                c = clearances(reference, xy, field_m)
                row["min_clearance_m"] = float(np.nanmin(c)) if np.isfinite(c).any() else None
        per_goal.append(row)
    out: dict[str, Any] = {
        "goals": per_goal,
        "goals_total": len(goals),
        "goals_succeeded": sum(g.status == "succeeded" for g in goals),
        "collisions": collisions,
        "recoveries": sum(len(g.recoveries) for g in goals),
    }
    if gt is not None and len(gt) > 1:
        dt = np.diff(gt.times_ns) / 1e9
        speed = np.hypot(*np.diff(gt.positions[:, :2], axis=0).T) / dt
        out["speed_mps"] = _stats(speed)
        if field_m is not None:
            c = clearances(reference, gt.positions[:, :2], field_m)
            out["min_clearance_m"] = float(np.nanmin(c)) if np.isfinite(c).any() else None
    if commands is not None:
        acc, jerk = command_jerk(*commands)
        out["command_accel_mps2"] = _stats(np.abs(acc))
        out["command_jerk_mps3"] = _stats(np.abs(jerk))
    return out
