"""The facts a case's invariants read, gathered from its replay: metrics, plans, safety, events.

Only the groups an invariant asks for are gathered (reading the input log's events streams one topic).
Every fact is a number or a flag; ``numbers`` keeps the numbers for the reports (JUnit properties).
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from navlog.analysis.diff.metric_values import flatten
from navlog.errors import NavlogError

__all__ = ["EVENTS_TOPIC", "case_facts", "min_clearance", "numbers"]

EVENTS_TOPIC = "/navlog/events"
PLAN_TOPIC = "/plan"
# short names of the metrics users ask for most
METRIC_ALIASES = {
    "metrics.ate.rmse": "metrics.trajectory.ate.translation_m.rmse",
    "metrics.rpe.rmse": "metrics.trajectory.rpe.translation_m.rmse",
}
Facts = dict[str, float | bool]


def case_facts(
    roots: Iterable[str],
    *,
    log: Path,
    replay_dir: Path,
    metrics: Mapping[str, Any] | None = None,
    static_map: Path | None = None,
    goals: int | None = None,
) -> Facts:
    """The facts of the groups in ``roots`` (``metrics``, ``plans``, ``goals``, ``min_clearance``,
    ``safety``, ``navigation``, ``events`` and the flags that derive from them)."""
    roots = set(roots)
    facts: Facts = {}
    if "metrics" in roots and metrics is not None:
        facts.update(_numbers(flatten(dict(metrics)), "metrics."))
        facts.update({short: facts[full] for short, full in METRIC_ALIASES.items() if full in facts})
    if roots & {"plans", "no_plan_failures"}:
        facts.update(_plans(replay_dir / "plans.json"))
    if roots & {"events", "no_collision", "goals", "all_goals_reached"}:
        logged, replayed = _event_kinds(log), _event_kinds(replay_dir / "replay.mcap")
        kinds = logged + replayed
        facts.update({f"events.{k}": float(n) for k, n in sorted(kinds.items())})
        facts["no_collision"] = kinds.get("collision", 0) == 0
        # goals: the replay's navigator when it ran one (a live run's are in the log too: not counted twice)
        goal_events = replayed if replayed.get("goal_accepted", 0) else logged
        reached = goal_events.get("goal_succeeded", 0)
        facts["goals.reached"] = float(reached)
        if goals is not None:
            facts["goals.total"] = float(goals)
            facts["all_goals_reached"] = goals > 0 and reached >= goals
    if "min_clearance" in roots and static_map is not None:
        clearance = min_clearance(replay_dir / "replay.mcap", static_map)
        if clearance is not None:
            facts["min_clearance"] = clearance
    if "navigation" in roots and (replay_dir / "navigation.json").is_file():
        facts.update(_numbers(flatten(_read_json(replay_dir / "navigation.json")), "navigation."))
    if "safety" in roots and (replay_dir / "safety.json").is_file():
        facts.update(_numbers(flatten(_read_json(replay_dir / "safety.json")), "safety."))
    return facts


def numbers(facts: Mapping[str, float | bool]) -> dict[str, float]:
    """The numeric facts (flags left out)."""
    return {k: float(v) for k, v in sorted(facts.items()) if not isinstance(v, bool)}


def _numbers(flat: Mapping[str, Any], prefix: str) -> Facts:
    return {prefix + k: v if isinstance(v, bool) else float(v) for k, v in flat.items() if isinstance(v, int | float)}


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise NavlogError(f"{path}: cannot read the replay's JSON: {exc}") from None


def _plans(path: Path) -> Facts:
    if not path.is_file():
        return {}
    data = _read_json(path)
    plans = data.get("plans", []) if isinstance(data, dict) else []
    failures = data.get("failures", []) if isinstance(data, dict) else []
    lengths = [float(p["length_m"]) for p in plans]
    costs = [float(p["cost"]) for p in plans]
    facts: Facts = {"plans.count": float(len(plans)), "plans.failures": float(len(failures))}
    facts["no_plan_failures"] = not failures
    if lengths:
        facts["plans.length_m.max"] = max(lengths)
        facts["plans.length_m.min"] = min(lengths)
        facts["plans.length_m.mean"] = sum(lengths) / len(lengths)
        facts["plans.cost.max"] = max(costs)
    return facts


def _event_kinds(log: Path) -> Counter[str]:
    from navlog.replay.io.formats import open_log

    kinds: Counter[str] = Counter()
    with open_log(log) as reader:
        if EVENTS_TOPIC in reader.topics:
            for env in reader.messages([EVENTS_TOPIC]):
                kinds[str(env.msg.kind)] += 1
    return kinds


def min_clearance(replay_log: Path, static_map: Path) -> float | None:
    """The smallest clearance (m) of a /plan pose to the occupied cells (>= 65) of the map, measured as the
    navigation metrics measure it (``clearance_field``); None when there is no plan pose on the map."""
    import numpy as np

    from navlog.analysis.metrics.navigation import clearance_field, clearances
    from navlog.replay.io.formats import open_log
    from navlog.replay.io.map_server import load_map

    grid = load_map(static_map)
    field = clearance_field(np.asarray(grid.data) >= 65, grid.resolution)
    xy: list[tuple[float, float]] = []
    with open_log(replay_log) as reader:
        if PLAN_TOPIC not in reader.topics:
            return None
        for env in reader.messages([PLAN_TOPIC]):
            xy += [(ps.pose.position.x, ps.pose.position.y) for ps in env.msg.poses]
    c = clearances(grid, np.asarray(xy, dtype=float).reshape(-1, 2), field)
    return float(np.nanmin(c)) if np.isfinite(c).any() else None
