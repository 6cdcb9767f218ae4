"""``run_suite``: every case of a suite, replayed and judged against its baseline and invariants.

Per case: get the log (a recipe is recorded once into the cache and its sha256 checked against the
baseline's provenance), check it for what the pipeline reads (a failure is INVALID_INPUT and the case
stops there), replay it (cached by log sha256, parameter hash and navlog version; ``determinism``
replays twice afresh and compares every output's bytes), compute the mapping metrics, diff the
outputs against the baseline, and evaluate the invariants. A case that raises is an ERROR with its
message; the other cases still run. ``workers > 1`` runs recipes, then cases, on the fleet's
``ProcessPool`` (``navlog.analysis.fleet.executors``): a worker process that dies (killed, out of
memory) is an ERROR of the one case it ran, naming it. The results are the same as serially (each
case's result depends only on its inputs).

``overrides`` (``--set KEY=VALUE``) apply to every case whose pipeline has KEY; a key no case's
pipeline has is refused (``ConfigError``) before anything runs.

Baselines: ``update`` rewrites every case's baseline, ``update_new`` writes those that are missing or
from another navlog version (a baseline from another version is NEW: compared, then a failure until
rewritten). The diff checks of a rewritten case compare against the new baseline (PASS); a note names
what moved against the old one.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TypeVar

from navlog.analysis.ci.baselines import Baseline, compare_to_baseline, read_baseline, unused_baselines, write_baseline
from navlog.analysis.ci.cache import (
    cached_log,
    cached_replay,
    cached_world_map,
    default_cache_dir,
    log_layout_sha256,
)
from navlog.analysis.ci.campaign_case import CampaignRunner, campaign_facts, evaluate_campaign
from navlog.analysis.ci.facts import case_facts, numbers
from navlog.analysis.ci.invariants import evaluate
from navlog.analysis.ci.result import CaseResult, CheckResult, Status, SuiteResult
from navlog.analysis.ci.suite import Case, Recipe, Suite, WorldMap, load_suite
from navlog.analysis.fleet.executors import Executor, InProcess, Lost, ProcessPool, run_jobs
from navlog.errors import ConfigError, NavlogError
from navlog.replay.config import suggest
from navlog.replay.identity import log_sha256, parameter_hash, replay_identity
from navlog.replay.io import json_text
from navlog.version import __version__

__all__ = ["DEFAULT_BASELINES", "applicable_overrides", "default_executor", "run_case", "run_suite"]

DEFAULT_BASELINES = Path("data/baselines")  # relative to the suite file's folder, as every path of a suite
METRICS_FILE = "metrics.json"
DEFAULT_MAP_RESOLUTION = 0.05  # m, a world map's cells when the case does not say

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class CaseJob:
    """Everything one case needs, picklable for a worker process."""

    case: Case
    overrides: tuple[str, ...]
    baseline: Path
    cache: Path
    update: bool = False
    update_new: bool = False
    determinism: bool = False
    log: Path | None = None  # the recorded log of a recipe
    log_error: str = ""  # why the recipe could not be recorded
    timings: dict[str, float] = field(default_factory=dict)
    campaign_runner: CampaignRunner | None = None  # runs a campaign case's file (module-level: picklable)


def _map(
    fn: Callable[[T], R],
    items: Sequence[T],
    executor: Executor,
    lost: Callable[[T, Lost], R],
) -> list[R]:
    """``fn`` of every item on ``executor``, in order; an item whose worker process died gives ``lost(item, why)``."""
    done = run_jobs(executor, fn, items)
    return [lost(item, r) if isinstance(r, Lost) else r for item, (r, _) in zip(items, done, strict=True)]


def default_executor(workers: int, jobs: int) -> Executor:
    """This process for one worker or one job, else a pool of ``min(workers, jobs)`` worker processes."""
    if workers <= 1 or jobs <= 1:
        return InProcess()
    return ProcessPool(min(workers, jobs))


def _has_key(tree: Any, key: str) -> bool:
    """Whether a parameter tree has the dotted ``key``; below a free-form mapping (an empty one in the
    defaults, such as the planner's Nav2 overrides) any key counts."""
    node = tree
    parts = key.split(".")
    for depth, part in enumerate(parts):
        if not isinstance(node, dict):
            return False
        if part not in node:
            return depth > 0 and not node
        node = node[part]
    return not isinstance(node, dict) or not node


def applicable_overrides(
    suite: Suite, overrides: Sequence[str], chosen: Sequence[str] = ()
) -> dict[str, tuple[str, ...]]:
    """Case name -> the ``--set`` items its pipeline has. A key no case has raises ``ConfigError``, and so
    does a key a case named in ``chosen`` (``--case``) lacks: asked for by name, it must take the key."""
    from navlog.replay.config import to_mapping
    from navlog.replay.session import pipeline_params

    out: dict[str, list[str]] = {c.name: [] for c in suite.cases}
    suite = replace(suite, cases=tuple(c for c in suite.cases if c.kind == "replay"))  # a campaign takes no --set
    trees = {p: to_mapping(pipeline_params(p)) for p in sorted({c.pipeline for c in suite.cases})}
    for item in overrides:
        key, sep, _ = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--set '{item}': expected KEY=VALUE, e.g. occupancy.grid.resolution=0.1")
        takers = [p for p, tree in trees.items() if _has_key(tree, key.strip())]
        for c in suite.cases:
            if c.pipeline not in takers and c.name in chosen:
                raise ConfigError(
                    f"--set '{item}': case '{c.name}' (pipeline {c.pipeline}) has no parameter '{key.strip()}'; "
                    "it would run without it (leave the case out or the --set)"
                )
        if not takers:
            from navlog.analysis.diff.metric_values import flatten

            keys = sorted({k for tree in trees.values() for k in flatten(tree)})
            raise ConfigError(
                f"--set '{item}': no case's pipeline ({', '.join(trees)}) has the parameter '{key.strip()}'"
                f"{suggest(key.strip(), keys)}"
            )
        for c in suite.cases:
            if c.pipeline in takers:
                out[c.name].append(item)
    return {k: tuple(v) for k, v in out.items()}


def _override_note(item: str, suite: Suite, applied: dict[str, tuple[str, ...]]) -> str:
    """What a ``--set`` applied to: every case, or the cases that took it and those that did not."""
    took = [c.name for c in suite.cases if item in applied[c.name]]
    left = [f"{c.name} ({c.pipeline})" for c in suite.cases if item not in applied[c.name]]
    if not left:
        return f"--set {item}: applied to every case"
    key = item.partition("=")[0].strip()
    return (
        f"--set {item}: applied to {', '.join(took)}; NOT applied to {', '.join(left)}: their pipelines have no "
        f"parameter '{key}'"
    )


def _record(job: tuple[Recipe, Path]) -> tuple[Path | None, str, float]:
    recipe, cache = job
    start = time.perf_counter()
    try:
        path, _ = cached_log(recipe, cache)
        return path, "", time.perf_counter() - start
    except NavlogError as exc:
        return None, str(exc), time.perf_counter() - start


def run_suite(
    suite_path: Path | str,
    *,
    update: bool = False,
    update_new: bool = False,
    determinism: bool = False,
    overrides: Sequence[str] = (),
    workers: int = 1,
    cache_dir: Path | str | None = None,
    baseline_dir: Path | str | None = None,
    cases: Sequence[str] = (),
    executor: Callable[[int, int], Executor] = default_executor,
    campaign_runner: CampaignRunner | None = None,
) -> SuiteResult:
    """Run every case of the suite file (or only those named in ``cases``); see the module docstring. A
    bad suite or ``--set`` raises ``ConfigError`` before anything runs; a bad case is an ERROR in the result.

    ``executor(workers, jobs)`` gives where the recordings, then the cases, run (``default_executor``: this
    process or a ``ProcessPool``); a case whose worker process dies is an ERROR naming it, and the
    other cases still run. ``campaign_runner`` runs the cases of kind campaign (``navlog ci run`` gives
    ``navlog.campaign.run_campaign_case``); without it such a case is an ERROR saying so."""
    suite = load_suite(suite_path)
    if cases:
        suite = replace(suite, cases=tuple(suite.case(n) for n in cases))
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    root = Path(baseline_dir) if baseline_dir is not None else suite.baselines or suite.path.parent / DEFAULT_BASELINES
    if root.exists() and not root.is_dir():
        raise ConfigError(f"{root}: the baselines' place is a file, not a folder; give a folder (--baselines DIR)")
    folder = root / suite.name
    extra = applicable_overrides(suite, overrides, chosen=cases)
    recipes = sorted({c.recipe for c in suite.cases if c.recipe is not None}, key=lambda r: repr(r))
    recordings = _map(_record, [(r, cache) for r in recipes], executor(workers, len(recipes)), _recording_lost)
    recorded = dict(zip(recipes, recordings, strict=True))
    jobs = []
    for c in suite.cases:
        log, error, seconds = recorded[c.recipe] if c.recipe is not None else (c.log, "", 0.0)
        jobs.append(
            CaseJob(
                c,
                extra[c.name],
                folder / c.name,
                cache,
                update,
                update_new,
                determinism,
                log,
                error,
                {"log": seconds},
                campaign_runner,
            )
        )
    results = _map(run_case, jobs, executor(workers, len(jobs)), _case_lost)
    unused = [] if cases else unused_baselines(folder, [c.name for c in suite.cases])
    notes = [_override_note(o, suite, extra) for o in overrides]
    return SuiteResult(suite.name, str(suite.path), __version__, tuple(results), tuple(unused), tuple(notes))


def _recording_lost(job: tuple[Recipe, Path], lost: Lost) -> tuple[Path | None, str, float]:
    recipe = job[0]
    return None, f"recording {recipe.world}/{recipe.robot}/{recipe.scenario}: {lost.reason}", 0.0


def _case_lost(job: CaseJob, lost: Lost) -> CaseResult:
    return _error(job, f"case '{job.case.name}': {lost.reason}", dict(job.timings))


def run_case(job: CaseJob) -> CaseResult:
    """One case; never raises: a failure to run is an ERROR check with its message."""
    timings = dict(job.timings)
    try:
        return _run_case(job, timings)
    except NavlogError as exc:
        message = str(exc)
    except Exception as exc:  # a defect: reported with the case, the other cases still run
        message = f"{type(exc).__name__}: {exc}"
    return _error(job, message, timings)


def _error(job: CaseJob, message: str, timings: dict[str, float]) -> CaseResult:
    case = job.case
    check = CheckResult("run", "error", Status.ERROR, message)
    return CaseResult(case.name, case.pipeline, case.source, (check,), timings=timings)


def _run_case(job: CaseJob, timings: dict[str, float]) -> CaseResult:
    from navlog.replay.pipelines import pipeline_spec
    from navlog.replay.session import pipeline_params

    case = job.case
    if case.kind == "campaign":
        return _run_campaign_case(job, timings)
    if job.log_error:
        raise NavlogError(job.log_error)
    log = job.log
    if log is None or not log.exists():
        raise NavlogError(f"case '{case.name}': log: {log}: no such file or folder")
    checks: list[CheckResult] = []
    notes: list[str] = []
    user_overrides = [*case.overrides, *job.overrides]
    overrides = list(user_overrides)
    pipeline = pipeline_spec(case.pipeline)
    params = pipeline_params(case.pipeline, case.params, overrides)
    spec = case.world_map
    if spec is not None and spec.resolution is None:  # the resolution of the map the pipeline makes
        resolution = pipeline.map_resolution(params)
        spec = replace(spec, resolution=DEFAULT_MAP_RESOLUTION if resolution is None else resolution)
    world_map = cached_world_map(spec, job.cache) if spec is not None else None
    key = pipeline.world_map_key
    if world_map is not None and key is not None and not any(o.startswith(f"{key}=") for o in overrides):
        overrides.insert(0, f"{key}={world_map}")  # e.g. the static map (its content counts in the parameter hash)
        params = pipeline_params(case.pipeline, case.params, overrides)
    remap = dict(case.remap)

    start = time.perf_counter()
    log_sha = log_sha256(log)
    checked = _input_check(log, case.pipeline, params, remap)
    timings["check"] = time.perf_counter() - start
    checks.append(checked)
    if checked.status is Status.INVALID_INPUT:
        return CaseResult(case.name, case.pipeline, case.source, tuple(checks), timings=timings)

    base = read_baseline(job.baseline)
    provenance = _provenance(case, spec, log_sha, parameter_hash(params), user_overrides)
    if case.recipe is not None:
        provenance["log"]["layout"] = log_layout_sha256(log)
    found = _provenance_checks(case, base, provenance, notes)
    if case.diff is not None and (job.update or (job.update_new and _stale(base))):
        notes += [f"{c.name}: {c.message}" for c in found if c.status.failed]  # the rewrite settles them
        found = [c for c in found if not c.status.failed]
    checks += found

    start = time.perf_counter()
    key = replay_identity(log_sha, case.pipeline, params, remap)
    with cached_replay(log, case.pipeline, params, remap, key, job.cache, fresh=job.determinism) as found_replay:
        replay_dir, cached = found_replay
        if job.determinism:
            checks.append(_determinism(log, case.pipeline, params, remap, replay_dir))
        timings["replay"] = time.perf_counter() - start

        start = time.perf_counter()
        manifest = json.loads((replay_dir / "manifest.json").read_text(encoding="utf-8"))
        metrics = _metrics(log, replay_dir, world_map, notes) if pipeline.scored_by_metrics else None
        written = False
        with tempfile.TemporaryDirectory(prefix="navlog-ci-") as work:
            outputs = {o["file"]: replay_dir / o["file"] for o in manifest["outputs"].values()}
            if metrics is not None:
                (Path(work) / METRICS_FILE).write_text(json_text.dumps(metrics, indent=2, sort_keys=True) + "\n")
                outputs[METRICS_FILE] = Path(work) / METRICS_FILE
            if case.diff is not None:
                diff_checks, written = _diff(job, base, outputs, provenance, notes)
                checks += diff_checks
        roots = {inv.roots() for inv in case.invariants} | set(pipeline.summary_facts)
        static_map, goals = pipeline.static_map(params), pipeline.goal_count(params)
        facts = case_facts(roots, log=log, replay_dir=replay_dir, metrics=metrics, static_map=static_map, goals=goals)
        checks += [evaluate(inv, facts) for inv in case.invariants]
    timings["compare"] = time.perf_counter() - start
    return CaseResult(
        case.name,
        case.pipeline,
        case.source,
        tuple(checks),
        numbers(facts),
        tuple(notes),
        written,
        timings,
        cached,
    )


def _run_campaign_case(job: CaseJob, timings: dict[str, float]) -> CaseResult:
    """A case of kind campaign: the campaign run into the cache (a rerun reuses its finished runs), each
    threshold judged on its summary; the facts are every variant's figures."""
    case = job.case
    assert case.campaign is not None
    if job.campaign_runner is None:
        raise NavlogError(
            f"case '{case.name}': a campaign case needs the campaign runner: run it with `navlog ci run`, or pass "
            "campaign_runner=navlog.campaign.run_campaign_case to run_suite"
        )
    start = time.perf_counter()
    out = job.cache / "campaigns" / f"{job.baseline.parent.name}-{case.name}"
    summary = job.campaign_runner(case.campaign, out)
    timings["campaign"] = time.perf_counter() - start
    checks = tuple(evaluate_campaign(c, summary) for c in case.campaign_checks)
    facts = campaign_facts(summary)
    notes = (f"campaign '{summary['campaign']}': {summary['runs']} rows, reports in {out}",)
    return CaseResult(case.name, case.pipeline, case.source, checks, facts, notes, timings=timings)


def _input_check(log: Path, pipeline: str, params: Any, remap: dict[str, str]) -> CheckResult:
    """``check_log`` for the topics this case's pipeline reads (after remapping): INVALID_INPUT on failure."""
    from navlog.analysis.check import check_log
    from navlog.replay.io.formats import open_log
    from navlog.replay.pipelines import pipeline_spec

    with open_log(log, recover=True) as reader:
        to_log = {v: k for k, v in remap.items()}
        topics = {to_log.get(t, t) for t in reader.topics}
        inputs = pipeline_spec(pipeline).build(params, topics).inputs
        result = check_log(reader, require=[remap.get(t, t) for t in inputs])
    counts = {str(s): n for s, n in result.to_dict()["counts"].items()}
    if result.failed:
        why = "; ".join(f"{c.subject}: {c.message}" for c in result.failed)
        return CheckResult("input", "input", Status.INVALID_INPUT, f"the log fails its checks: {why}", counts)
    return CheckResult("input", "input", Status.PASS, f"{len(result.checks)} checks, none failed", counts)


def _provenance(
    case: Case, world_map: WorldMap | None, log_sha: str, param_hash: str, overrides: list[str]
) -> dict[str, Any]:
    log: dict[str, Any] = {"sha256": log_sha}
    if case.recipe is not None:
        log["recipe"] = case.recipe.to_dict()
    else:
        log["file"] = Path(str(case.log)).name
    return {
        "navlog_version": __version__,
        "pipeline": case.pipeline,
        "parameter_hash": param_hash,
        "params_file": case.params.name if case.params is not None else None,
        "overrides": list(overrides),
        "remap": dict(case.remap),
        "world_map": None
        if world_map is None
        else {"world": world_map.world, "margin": world_map.margin, "resolution": world_map.resolution},
        "log": log,
    }


def _stale(base: Baseline | None) -> bool:
    return base is None or base.navlog_version != __version__


def _rounds_otherwise(base: Baseline, provenance: dict[str, Any]) -> bool:
    """True when the log is the baseline's recipe recorded with other bytes and the same layout (a machine
    whose floating point rounds otherwise)."""
    old, new = base.provenance.get("log", {}), provenance.get("log") or {}
    return (
        "recipe" in new
        and old.get("sha256") != new.get("sha256")
        and old.get("layout") is not None
        and old.get("layout") == new.get("layout")
        and old.get("recipe") == new.get("recipe")
    )


def _provenance_checks(
    case: Case, base: Baseline | None, provenance: dict[str, Any], notes: list[str]
) -> list[CheckResult]:
    if base is None:
        return []
    out: list[CheckResult] = []
    old = base.provenance
    if case.recipe is not None:
        want, have = old.get("log", {}).get("sha256"), provenance["log"]["sha256"]
        if want == have:
            out.append(
                CheckResult("recipe", "recipe", Status.PASS, f"recorded log sha256 {have[:16]} as in the baseline")
            )
        elif _rounds_otherwise(base, provenance):
            out.append(
                CheckResult(
                    "recipe",
                    "recipe",
                    Status.PASS,
                    f"recorded log sha256 {have[:16]}, the baseline's was {str(want)[:16]}, with the same topics, "
                    "message times and sizes: this machine rounds otherwise (NumPy's BLAS kernels are chosen by "
                    "CPU); the outputs are compared within the tolerances",
                    {"sha256": have, "baseline_sha256": want},
                )
            )
        else:
            out.append(
                CheckResult(
                    "recipe",
                    "recipe",
                    Status.FAIL,
                    f"the recipe recorded a log with sha256 {have[:16]}, the baseline's was {str(want)[:16]}: "
                    "the recorder, the world, robot or scenario changed",
                    {"sha256": have, "baseline_sha256": want},
                )
            )
    if base.navlog_version != __version__:
        out.append(
            CheckResult(
                "baseline",
                "baseline",
                Status.NEW,
                f"the baseline was written by navlog {base.navlog_version}, this is navlog {__version__}: outputs "
                "are compared, but the baseline stays NEW until rewritten (--update-new or --update)",
            )
        )
    if case.recipe is None and old.get("log", {}).get("sha256") != provenance["log"]["sha256"]:
        notes.append(
            f"the log differs from the baseline's (sha256 {str(old.get('log', {}).get('sha256'))[:12]} -> "
            f"{provenance['log']['sha256'][:12]}): the outputs are compared as for any change"
        )
    if old.get("parameter_hash") != provenance["parameter_hash"]:
        notes.append(
            f"parameters differ from the baseline's (hash {str(old.get('parameter_hash'))[:12]} -> "
            f"{provenance['parameter_hash'][:12]})"
        )
    return out


def _determinism(log: Path, pipeline: str, params: Any, remap: dict[str, str], first: Path) -> CheckResult:
    from navlog.replay.session import run_replay

    with tempfile.TemporaryDirectory(prefix="navlog-ci-again-") as tmp:
        second = run_replay(log, pipeline, Path(tmp) / "out", params=params, remap=remap, progress=False).manifest
    a = json.loads((first / "manifest.json").read_text(encoding="utf-8"))["outputs"]
    b = second["outputs"]
    differ = sorted(v["file"] for k, v in a.items() if b.get(k, {}).get("sha256") != v["sha256"]) + sorted(
        v["file"] for k, v in b.items() if k not in a
    )
    if differ:
        return CheckResult(
            "determinism",
            "determinism",
            Status.NONDETERMINISTIC,
            f"two replays of the same log with the same parameters differ in {', '.join(differ)}",
            {"differ": differ},
        )
    return CheckResult("determinism", "determinism", Status.PASS, f"two replays: {len(a)} outputs, same bytes")


def _metrics(log: Path, replay_dir: Path, world_map: Path | None, notes: list[str]) -> dict[str, Any] | None:
    """The metrics of a mapping replay, without the paths they were read from (those vary by machine); None,
    said in ``notes``, when the log holds nothing to score against (a real robot's bag: no ground truth, no
    reference map). The case's diff and invariants run either way; an invariant on a metric then fails."""
    from navlog.analysis.metrics import compute_metrics

    try:
        metrics = compute_metrics(log, replay_dir, reference_map=world_map)
    except NavlogError as exc:
        if not str(exc).startswith("no metric could be computed"):
            raise
        notes.append(f"no metrics: {exc}".replace("no metrics: no metric could be computed: ", "no metrics: "))
        return None
    metrics.pop("inputs", None)
    return metrics


def _diff(
    job: CaseJob, base: Baseline | None, outputs: dict[str, Path], provenance: dict[str, Any], notes: list[str]
) -> tuple[list[CheckResult], bool]:
    diff = job.case.diff
    assert diff is not None
    if job.update or (job.update_new and _stale(base)):
        if base is not None:
            moved = [
                c.name for c in compare_to_baseline(base, outputs, diff.tolerances, diff.ignore) if c.status.failed
            ]
            notes.append(
                "baseline rewritten"
                + (f"; moved against the old one: {', '.join(moved)}" if moved else "; nothing moved")
            )
        else:
            notes.append("baseline written")
        write_baseline(job.baseline, outputs, provenance, label=job.case.name)
        base = read_baseline(job.baseline)
        assert base is not None
        return compare_to_baseline(base, outputs, diff.tolerances, diff.ignore), True
    if base is None:
        message = f"no baseline in {job.baseline}: write it with --update-new (then review and commit it)"
        return [CheckResult("baseline", "baseline", Status.NEW, message)], False
    rounds = _rounds_otherwise(base, provenance)
    found = compare_to_baseline(base, outputs, diff.tolerances, diff.ignore, log_rounds_otherwise=rounds)
    if not rounds:  # (where the machine rounds otherwise, the recipe check says so once)
        notes += [f"{c.name}: {c.message}" for c in found if c.values.get("hash_only")]
    return found, False
