"""``run_campaign``: every world x robot x seed x route x variant of a campaign, one isolated job each.

Planning (here, before anything runs; every error is a ConfigError): generated worlds are written to
``OUT/worlds/NAME.yaml`` (the YAML ``navlog world-gen`` writes), each variant's Nav2 file with its
overrides to ``OUT/variants/NAME.yaml`` and checked, the routes drawn (seeded) and each route's optimal
path planned by NavFn on the true grid (``navlog.recorder.routes``). A route no path reaches is an
``infeasible`` row: not run, and left out of the success rate (it is not the stack's failure).

Running: each job (``run_job``) records the run into a temporary MCAP (``navlog.recorder.record``),
reads its metrics back, and writes its row to ``OUT/runs/RUN.json`` whole (a temporary file renamed).
A rerun reuses every row whose job is unchanged (its ``key``), so an interrupted campaign resumes.
A run that raises, crashes its process (``Lost``) or exceeds ``wall_timeout`` is one ``failed`` row;
the campaign goes on. Logs are kept in ``OUT/logs/`` only when asked (``keep_logs``: all or failed).
"""

from __future__ import annotations

import glob as globbing
import hashlib
import json
import math
import multiprocessing
import re
import shutil
import signal
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from navlog.campaign.spec import CampaignSpec, load_campaign
from navlog.errors import ConfigError, NavlogError
from navlog.replay.io.atomic import hold_output, write_error
from navlog.version import __version__

KeepLogs = Literal["none", "all", "failed"]
RESULTS = ("succeeded", "collision", "timeout", "aborted", "failed", "infeasible")
ROW_VERSION = 2  # bumped when a row's fields or their meaning change (old rows are then redone)


@dataclass(frozen=True)
class RunJob:
    """Everything one run needs (picklable, for worker processes and Ray tasks)."""

    run_id: str
    key: str  # hash of everything the row depends on
    world: str
    world_path: str
    robot: str
    variant: str
    nav2_path: str
    seed: int
    route: int
    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    noise: bool
    localization: str
    max_duration: float
    map_margin: float
    wall_timeout: float
    out: str
    keep_logs: str
    difficulty: float
    optimal_path_m: float
    optimal_time_s: float


@dataclass
class CampaignResult:
    spec: CampaignSpec
    out: Path
    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    files: list[Path] = field(default_factory=list)
    wall_s: float = 0.0
    cached: int = 0


class _WallTimeout(Exception):
    pass


def run_job(job: RunJob) -> dict[str, Any]:
    """Run one job (module docstring); never raises: a failure is a row with ``result: failed``. In a worker
    process, a run the wall-time limit stopped comes back as ``Spent``: its process is not reused."""
    out = Path(job.out)
    row_path = out / "runs" / f"{job.run_id}.json"
    cached = _cached_row(row_path, job.key)
    if cached is not None and not (_keeps_log(job, cached) and "log" not in cached):  # (its log asked for now)
        cached["cached"] = True
        return cached
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="navlog-campaign-") as tmp:
        log = Path(tmp) / f"{job.run_id}.mcap"
        try:
            with _wall_limit(job.wall_timeout):
                row = _run(job, log, Path(tmp))
        except _WallTimeout:
            row = _base_row(job) | {"result": "failed", "message": f"hung: over {job.wall_timeout:g} s of wall time"}
        except NavlogError as exc:
            row = _base_row(job) | {"result": "failed", "message": str(exc)}
        except Exception as exc:  # a defect or a crash inside the run: this run fails, the campaign goes on
            row = _base_row(job) | {"result": "failed", "message": f"{type(exc).__name__}: {exc}"}
        if _keeps_log(job, row) and log.is_file():
            (out / "logs").mkdir(parents=True, exist_ok=True)
            shutil.move(log, out / "logs" / log.name)
            row["log"] = f"logs/{log.name}"
    row["wall_s"] = round(time.perf_counter() - start, 3)
    _write_row(row_path, row)
    row["cached"] = False
    if row.get("message", "").startswith("hung:") and multiprocessing.parent_process() is not None:
        from navlog.analysis.fleet.executors import Spent

        return Spent(row)  # type: ignore[return-value]  # the timer fired anywhere: this worker is not reused
    return row


def _keeps_log(job: RunJob, row: dict[str, Any]) -> bool:
    """Whether ``--keep-logs`` keeps the log of a run that ended as ``row`` says."""
    return job.keep_logs == "all" or (job.keep_logs == "failed" and row["result"] != "succeeded")


def _cached_row(path: Path, key: str) -> dict[str, Any] | None:
    try:
        row = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    # a failed run (an error, a crash, a hang) is run again; any other finished row is reused
    return row if isinstance(row, dict) and row.get("key") == key and row.get("result") != "failed" else None


def _write_row(path: Path, row: dict[str, Any]) -> None:
    from navlog.replay.io import json_text
    from navlog.replay.io.atomic import write_file

    write_file(path, (json_text.dumps(row, indent=1, sort_keys=True) + "\n").encode())


class _wall_limit:
    """Raise ``_WallTimeout`` in this thread after ``seconds`` of wall time (main thread only: SIGALRM)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.armed = threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")

    def _fire(self, signum: int, frame: Any) -> None:
        raise _WallTimeout

    def __enter__(self) -> None:
        if self.armed:
            self.previous = signal.signal(signal.SIGALRM, self._fire)
            signal.setitimer(signal.ITIMER_REAL, self.seconds)

    def __exit__(self, *exc: object) -> None:
        if self.armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self.previous)


def _base_row(job: RunJob) -> dict[str, Any]:
    return {
        "version": ROW_VERSION,
        "key": job.key,
        "run_id": job.run_id,
        "world": job.world,
        "robot": job.robot,
        "variant": job.variant,
        "seed": job.seed,
        "route": job.route,
        "start": list(job.start),
        "goal": list(job.goal),
        "difficulty": job.difficulty,
        "optimal_path_m": job.optimal_path_m,
        "optimal_time_s": job.optimal_time_s,
        "result": "failed",
        "code": 0,
        "message": "",
    }


def _run(job: RunJob, log: Path, tmp: Path) -> dict[str, Any]:
    from navlog.recorder.description import load_robot
    from navlog.recorder.navigation import navigation_pipeline
    from navlog.recorder.record import RecordSetup, record
    from navlog.recorder.scenarios import ScenarioSpec, check_scenario
    from navlog.recorder.world import load_world, occupancy
    from navlog.replay.nodes.navigation import NavigationNode

    goals = tmp / "goals.yaml"
    x, y, yaw = job.goal
    goals.write_text(f"frame_id: map\ngoals:\n  - {{name: goal, x: {x!r}, y: {y!r}, yaw: {yaw!r}}}\n")
    scenario = ScenarioSpec(
        name=job.run_id,
        kind="navigate",
        start=job.start,
        nav2_params=job.nav2_path,
        goals=str(goals),
        map_margin=job.map_margin,
        max_duration=job.max_duration,
        hold=0.5,
    )
    world = load_world(job.world_path)
    robot = load_robot(job.robot)
    check_scenario(scenario, robot, world)
    setup = RecordSetup(world, robot, scenario, job.seed, job.noise, job.localization)
    navigation = navigation_pipeline(scenario, job.seed, command_topic=robot.cmd_topic)
    timer = next(n for n in navigation.nodes if isinstance(n, NavigationNode))
    timer.cycle_wall_s = []
    res = record(setup, log, progress=False, sensor_worker=False, navigation=navigation)
    row = _base_row(job) | {"sim_s": round(res.sim_s, 3), "cycles": len(timer.cycle_wall_s)}
    row |= cycle_time_ms(timer.cycle_wall_s)
    nav, track = _log_metrics(log, robot.cmd_topic, occupancy(world, margin=0.0))
    goal = (nav or {}).get("goals", [{}])[0] if nav else {}
    status = goal.get("status", "unfinished")
    if res.collisions:
        row["result"] = "collision"
    elif status == "succeeded":
        row["result"] = "succeeded"
    elif status == "failed":
        row["result"] = "aborted"
    else:
        row["result"] = "timeout"
    row["code"] = int(goal.get("code", 0) or 0)
    row["message"] = {
        "succeeded": "",
        "collision": f"{res.collisions} contact(s) with the world",
        "timeout": f"goal still open after max_duration {job.max_duration:g} s",
    }.get(row["result"], str(goal.get("message", "")))
    t = float(goal.get("time_s", res.sim_s))
    row["time_s"] = round(t, 3)
    row["path_length_m"] = _round(goal.get("path_length_m"))
    row["min_clearance_m"] = _round((nav or {}).get("min_clearance_m"))
    row["collisions"] = res.collisions
    row["recoveries"] = int(goal.get("recoveries", 0))
    for name, key in (("speed", "speed_mps"), ("accel", "command_accel_mps2"), ("jerk", "command_jerk_mps3")):
        stats = (nav or {}).get(key) or {}
        row[f"{name}_mean"] = _round(stats.get("mean"))
        row[f"{name}_max"] = _round(stats.get("max"))
    row["barn_metric"] = round(barn_metric(row["result"] == "succeeded", t, job.optimal_time_s), 6)
    row["track"] = track
    return row


def cycle_time_ms(seconds: Sequence[float]) -> dict[str, float | None]:
    """Mean and 95th percentile (linear interpolation) of the controller's cycle wall times, in ms: figures
    of the machine that ran the run, kept out of the deterministic rows (``report.MACHINE``)."""
    if not len(seconds):
        return {"cycle_ms_mean": None, "cycle_ms_p95": None}
    import numpy as np

    ms = np.asarray(seconds, dtype=float) * 1e3
    return {"cycle_ms_mean": round(float(ms.mean()), 3), "cycle_ms_p95": round(float(np.percentile(ms, 95)), 3)}


def _round(v: Any, digits: int = 4) -> float | None:
    return None if v is None or not math.isfinite(float(v)) else round(float(v), digits)


def barn_metric(success: bool, time_s: float, optimal_time_s: float) -> float:
    """The BARN challenge's score of one run: success x optimal time / clip(time, 4 x optimal, 8 x optimal)."""
    if not success or optimal_time_s <= 0:
        return 0.0
    return optimal_time_s / min(max(time_s, 4 * optimal_time_s), 8 * optimal_time_s)


TRACK_PERIOD_NS = 250_000_000  # the driven trajectory kept in a row: one ground-truth x, y every 0.25 s


def _log_metrics(log: Path, cmd_topic: str, reference: Any) -> tuple[dict[str, Any] | None, list[list[float]]]:
    """The run's navigation metrics and its driven trajectory (x, y in m every 0.25 s, for the contact sheet)."""
    import numpy as np

    from navlog.analysis.metrics.navigation import navigation_metrics
    from navlog.analysis.metrics.report import ground_truth_trajectory, read_commands, read_events
    from navlog.replay.io import open_log

    with open_log(log) as reader:
        gt, _ = ground_truth_trajectory(reader)
        nav = navigation_metrics(read_events(reader), gt, read_commands(reader, cmd_topic), reference)
    t = np.asarray(gt.times_ns, dtype=np.int64)
    keep = np.flatnonzero(np.diff(t // TRACK_PERIOD_NS, prepend=-1) != 0) if len(t) else np.zeros(0, dtype=int)
    if len(t) and keep[-1] != len(t) - 1:
        keep = np.append(keep, len(t) - 1)
    track = [[round(float(x), 3), round(float(y), 3)] for x, y in gt.positions[keep, :2]]
    return nav, track


# ---------------------------------------------------------------- planning


@dataclass
class CampaignPlan:
    jobs: list[RunJob]
    infeasible: list[dict[str, Any]]  # rows of routes no path reaches
    worlds: dict[str, dict[str, Any]]  # name -> what is known of it (path, generator info)


def _sha256(path: Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return ""


def _resolve_worlds(spec: CampaignSpec, folder: Path, out: Path) -> list[tuple[str, str, dict[str, Any]]]:
    """(name, path, info) of every world, generated ones written to ``OUT/worlds/``."""
    from navlog.recorder.generators import generate_world, world_yaml
    from navlog.replay.io.atomic import write_file

    worlds: list[tuple[str, str, dict[str, Any]]] = []
    for i, src in enumerate(spec.worlds):
        where = f"worlds[{i}]"
        if src.generate:
            (out / "worlds").mkdir(parents=True, exist_ok=True)
            for seed in range(src.seed, src.seed + src.count):
                gen = generate_world(src.generate, seed, src.params, where)
                path = out / "worlds" / f"{gen.spec.name}.yaml"
                text = world_yaml(gen).encode()
                if not path.is_file() or path.read_bytes() != text:
                    write_file(path, text)
                worlds.append((gen.spec.name, str(path), gen.info))
        elif src.glob:
            pattern = src.glob if Path(src.glob).is_absolute() else str(folder / src.glob)
            found = sorted(globbing.glob(pattern))
            if not found:
                raise ConfigError(f"{where}.glob: '{src.glob}' matches no file (searched {pattern})")
            worlds += [(Path(p).stem, p, {}) for p in found]
        else:
            given = Path(src.file)
            where_file = given if given.is_absolute() or not (folder / given).exists() else folder / given
            worlds.append((given.stem, str(where_file), {}))
    names = [w[0] for w in worlds]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"worlds: two worlds are named '{dup[0]}'; rename one file (names key the runs)")
    return worlds


def _variant_files(spec: CampaignSpec, folder: Path, out: Path) -> dict[str, Path]:
    """Each variant's Nav2 file with its overrides, written to ``OUT/variants/NAME.yaml`` and checked."""
    from navlog.replay.config import dump_yaml, load_yaml
    from navlog.replay.io.atomic import write_file
    from navlog.replay.nav2 import load_nav2_params
    from navlog.replay.nav2.params import apply_nav2_overrides
    from navlog.replay.pipelines.safety import nav2_file

    (out / "variants").mkdir(parents=True, exist_ok=True)
    files = {}
    for i, v in enumerate(spec.variants):
        where = f"variants[{i}] ({v.name})"
        local = folder / v.nav2_params
        try:
            source = local if local.is_file() else nav2_file(v.nav2_params)
            doc = load_yaml(Path(source))
            if v.set:
                doc = apply_nav2_overrides(doc, list(v.set), source=str(source))
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        text = f"# variant {v.name}: {source}" + "".join(f" {s}" for s in v.set) + "\n"
        text += dump_yaml(doc)
        path = out / "variants" / f"{v.name}.yaml"
        if not path.is_file() or path.read_text() != text:
            write_file(path, text.encode())
        try:
            load_nav2_params(path).require_valid()
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        files[v.name] = path
    return files


def plan_campaign(spec: CampaignSpec, folder: Path, out: Path, keep_logs: KeepLogs = "none") -> CampaignPlan:
    """The jobs of ``spec`` (module docstring); ``folder``: where the campaign file's paths start."""
    from navlog.recorder.description import load_robot
    from navlog.recorder.record import robot_mapping
    from navlog.recorder.routes import optimal_path, true_grid
    from navlog.recorder.world import load_world
    from navlog.replay.config import config_hash

    worlds = _resolve_worlds(spec, folder, out)
    nav2 = _variant_files(spec, folder, out)
    robots = {}
    for i, name in enumerate(spec.robots):
        try:
            robots[name] = load_robot(name)
        except ConfigError as exc:
            raise ConfigError(f"robots[{i}]: {exc}") from None
    # a run's id names its files: a robot given as a path goes by its name there (two of one name are refused)
    ids = {name: re.sub(r"[^A-Za-z0-9_.-]", "_", robot.name) for name, robot in robots.items()}
    twice = sorted({i for i in ids.values() if list(ids.values()).count(i) > 1})
    if twice:
        raise ConfigError(f"robots: two robots are named '{twice[0]}'; give each its own name")
    # what a robot's runs depend on: its whole configuration (a YAML or description file edited redoes them)
    robot_keys = {name: config_hash(robot_mapping(robot)) for name, robot in robots.items()}
    jobs: list[RunJob] = []
    infeasible: list[dict[str, Any]] = []
    info: dict[str, dict[str, Any]] = {}
    for wname, wpath, winfo in worlds:
        world = load_world(wpath)
        grid = true_grid(world)
        # a generated world by its place in OUT (the reports' bytes must not depend on where OUT is)
        inside = Path(wpath).resolve().is_relative_to(out.resolve())
        info[wname] = {
            "path": Path(wpath).resolve().relative_to(out.resolve()).as_posix() if inside else wpath,
            **winfo,
        }
        world_sha = _sha256(Path(wpath))
        for rname, robot in robots.items():
            for seed in spec.seeds:
                routes = _routes(spec, world, winfo, robot.radius, seed, grid)
                for k, (start, goal) in enumerate(routes):
                    path = optimal_path(grid, start, goal, robot.radius)
                    length = path.length_m if path is not None else math.nan
                    ot = length / robot.drive.max_vx if path is not None else math.nan
                    for v in spec.variants:
                        run_id = f"{wname}-{ids[rname]}-s{seed}-r{k}-{v.name}"
                        content = {
                            "v": ROW_VERSION,
                            "navlog": __version__,
                            "world": world_sha,
                            "robot": robot_keys[rname],
                            "nav2": _sha256(nav2[v.name]),
                            "seed": seed,
                            "start": start,
                            "goal": goal,
                            "spec": [spec.noise, spec.localization, spec.max_duration, spec.map_margin],
                        }
                        job = RunJob(
                            run_id,
                            config_hash(content),
                            wname,
                            wpath,
                            rname,
                            v.name,
                            str(nav2[v.name].resolve()),
                            seed,
                            k,
                            start,
                            goal,
                            spec.noise,
                            spec.localization,
                            spec.max_duration,
                            spec.map_margin,
                            spec.wall_timeout,
                            str(out.resolve()),
                            keep_logs,
                            round(path.difficulty, 4) if path is not None else math.nan,
                            round(length, 4),
                            round(ot, 4),
                        )
                        if path is None:
                            infeasible.append(
                                _base_row(job) | {"result": "infeasible", "message": "no path reaches the goal"}
                            )
                        else:
                            jobs.append(job)
    return CampaignPlan(jobs, infeasible, info)


def _routes(spec: CampaignSpec, world: Any, winfo: dict[str, Any], radius: float, seed: int, grid: Any) -> list:
    from navlog.recorder.routes import sample_routes

    r = spec.routes
    if r.kind == "fixed":
        return [(tuple(r.start), tuple(r.goal))]
    if r.kind == "auto" and "start" in winfo and "goal" in winfo:
        return [(tuple(winfo["start"]), tuple(winfo["goal"]))]
    # the margin counts beyond the obstacles' growth on /map: a start Nav2 sees in an obstacle is no route
    margin = r.margin + spec.map_margin
    return sample_routes(world, radius, r.count, seed, min_distance=r.min_distance, margin=margin, grid=grid)


# ---------------------------------------------------------------- the campaign


def make_executor(workers: int | None = None, ray: str | bool | None = None) -> Any:
    """The executor of ``workers`` (1: this process; None: the usable CPUs) or Ray (True: a local instance)."""
    from navlog.analysis.fleet.executors import InProcess, ProcessPool, RayPool
    from navlog.replay.runtime.cpus import usable_cpus

    if ray:
        return RayPool(None if ray is True else str(ray))
    n = usable_cpus() if workers is None else workers
    return InProcess() if n == 1 else ProcessPool(n)


def run_campaign(
    campaign: CampaignSpec | Path | str,
    out: Path | str,
    *,
    workers: int | None = None,
    ray: str | bool | None = None,
    executor: Any = None,
    keep_logs: KeepLogs = "none",
    progress: bool = True,
    only: Sequence[str] = (),
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> CampaignResult:
    """Run a campaign (a file or a ``CampaignSpec``) into ``out`` and write its reports
    (``navlog.campaign.report``); see the module docstring. ``only``: run only these variants."""
    from contextlib import closing

    from navlog.analysis.fleet.executors import Lost, run_jobs
    from navlog.analysis.fleet.progress import FleetProgress
    from navlog.campaign.report import write_reports
    from navlog.campaign.stats import summarize

    if keep_logs not in ("none", "all", "failed"):
        raise ConfigError(f"keep_logs '{keep_logs}': expected none, all or failed")
    if isinstance(campaign, CampaignSpec):
        spec, folder = campaign, Path.cwd()
    else:
        spec, folder = load_campaign(campaign), Path(campaign).parent
    names = [v.name for v in spec.variants]
    for name in only:
        if name not in names:
            from navlog.replay.config import suggest

            raise ConfigError(
                f"--variant '{name}' is not a variant of '{spec.name}'{suggest(name, names)}; variants: "
                + ", ".join(names)
            )
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: exists and is not a folder; choose another output folder")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(out.parent, exc) from None
    with hold_output(out):  # one run writes a campaign folder at a time
        made = not out.exists()
        out.mkdir(exist_ok=True)
        try:
            plan = plan_campaign(spec, folder, out, keep_logs)
            jobs = [j for j in plan.jobs if not only or j.variant in only]
            if not jobs:
                raise ConfigError(
                    f"campaign '{spec.name}' has 0 runs to do"
                    + (f" ({len(plan.infeasible)} route(s) infeasible)" if plan.infeasible else "")
                    + "; add worlds, seeds or routes"
                )
        except BaseException as exc:  # a campaign refused before its first run leaves no folder it made
            if made:
                shutil.rmtree(out, ignore_errors=True)
            if isinstance(exc, ConfigError) and not isinstance(campaign, CampaignSpec):
                said = str(exc)
                if not said.startswith(str(campaign)):  # the campaign file that holds the key named
                    raise ConfigError(f"{campaign}: {said}") from None
            raise
        start = time.perf_counter()
        ex = executor if executor is not None else make_executor(workers, ray)
        with closing(FleetProgress(len(jobs), enabled=progress)) as bar:

            def done(i: int, result: Any, attempts: int) -> None:
                row = _lost_row(jobs[i], result) if isinstance(result, Lost) else result
                bar.done(jobs[i].run_id, row["result"] != "failed", row.get("message", ""))
                if on_row is not None:
                    on_row(row)

            results = run_jobs(ex, run_job, jobs, on_done=done)
        rows = [_lost_row(j, r) if isinstance(r, Lost) else r for j, (r, _) in zip(jobs, results)]
        cached = sum(bool(r.pop("cached", False)) for r in rows)
        rows = sorted(rows + plan.infeasible, key=lambda r: r["run_id"])
        summary = summarize(rows, spec, plan.worlds)
        files = write_reports(out, rows, summary)
        return CampaignResult(spec, out, rows, summary, files, time.perf_counter() - start, cached)


def run_campaign_case(campaign: Path, out: Path) -> dict[str, Any]:
    """The summary of ``campaign`` run into ``out`` in this process: a ``navlog ci run`` case of kind
    campaign (``navlog.analysis.ci.campaign_case``; a rerun reuses every finished run)."""
    return run_campaign(campaign, out, workers=1, progress=False).summary


def _lost_row(job: RunJob, lost: Any) -> dict[str, Any]:
    row = _base_row(job) | {"result": "failed", "message": f"crashed: {lost.reason}"}
    _write_row(Path(job.out) / "runs" / f"{job.run_id}.json", row)  # failed: redone by the next run (no key match)
    return row


def rows_of(out: Path | str) -> list[dict[str, Any]]:
    """The rows of a campaign's output folder (``OUT/runs/*.json``), by run id."""
    return [json.loads(p.read_text()) for p in sorted(Path(out, "runs").glob("*.json"))]


__all__ = [
    "CampaignPlan",
    "CampaignResult",
    "RunJob",
    "barn_metric",
    "cycle_time_ms",
    "plan_campaign",
    "run_campaign",
    "run_campaign_case",
    "run_job",
]
