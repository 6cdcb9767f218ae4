"""``replay_fleet``: many logs replayed through one pipeline, one output folder each, one summary.

The logs (paths, folders, globs, list files, URLs: ``navlog.analysis.fleet.inputs``) are replayed by
``replay_log`` (``navlog.analysis.fleet.worker``) on an executor — in this process, a local process
pool (``workers``, default: the CPU count) or Ray (``ray=True`` for a local instance, or a cluster's
address) — each into ``OUT/NAME/`` exactly as ``navlog replay LOG -o OUT/NAME`` writes it. A log that
fails is a failed row with its reason; the rest of the fleet goes on. Up-to-date outputs are reused
(``force`` redoes them). At the end ``OUT/fleet-summary.{json,csv,md}`` hold one row per log and the
totals. Outputs may be local folders or ``fsspec`` URLs.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from contextlib import closing, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navlog.analysis.fleet.executors import Executor, InProcess, Lost, ProcessPool, RayPool, run_jobs
from navlog.analysis.fleet.inputs import collect_logs
from navlog.analysis.fleet.progress import FleetProgress
from navlog.analysis.fleet.storage import is_url, join, local_path, private_to_process, write_bytes
from navlog.analysis.fleet.summary import (
    NUMERIC_COLUMNS,
    SUMMARY_FILES,
    summary_document,
    summary_table,
    to_csv,
    to_json,
    to_markdown,
)
from navlog.analysis.fleet.worker import LogJob, LogResult, replay_log
from navlog.errors import ConfigError
from navlog.replay.io.atomic import hold_output, write_error
from navlog.version import __version__

__all__ = ["FleetResult", "format_fleet", "make_executor", "replay_fleet"]


@dataclass
class FleetResult:
    """What a fleet replay did: one ``LogResult`` per log (in the order named), the summary document,
    where its files are, which executor ran it and the wall time."""

    out: str
    pipeline: str
    executor: str
    results: list[LogResult]
    summary: dict[str, Any]
    files: dict[str, str]
    wall_s: float

    @property
    def failed(self) -> list[LogResult]:
        return [r for r in self.results if not r.ok]


def make_executor(
    *,
    workers: int | None = None,
    ray: bool | str = False,
    jobs: int = 0,
    cpus_per_log: float = 1.0,
    memory_per_log: int | None = None,
) -> Executor:
    """Ray when ``ray`` is set (``True``: a local instance of ``workers`` CPUs; a string: a cluster's
    address), else a process pool of ``workers`` (default: the CPU count; never more than ``jobs``),
    else (one worker or one job) this process."""
    if ray:
        return RayPool(
            ray if isinstance(ray, str) else None, cpus=cpus_per_log, memory=memory_per_log, local_cpus=workers
        )
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n < 1:
        raise ConfigError(f"--workers {n}: expected 1 or more")
    n = min(n, jobs) if jobs else n
    return ProcessPool(n) if n > 1 else InProcess()


def replay_fleet(
    logs: Sequence[str | Path],
    pipeline: str,
    out: str | Path,
    *,
    lists: Sequence[str | Path] = (),
    params: Any = None,
    overrides: Sequence[str] = (),
    remap: dict[str, str] | None = None,
    recover: bool = False,
    force: bool = False,
    workers: int | None = None,
    ray: bool | str = False,
    retries: int = 0,
    metrics: bool = True,
    cpus_per_log: float = 1.0,
    memory_per_log: int | None = None,
    progress: bool = True,
    executor: Executor | None = None,
) -> FleetResult:
    """Replay every log through ``pipeline`` into ``out`` (see the module docstring).

    ``params`` (or the pipeline's YAML plus ``overrides``), ``remap`` and ``recover`` are those of
    ``run_replay``; ``retries`` reruns a log whose worker died or whose storage failed; ``metrics``
    computes the mapping pipeline's trajectory errors for the summary; ``cpus_per_log`` and
    ``memory_per_log`` (bytes) are each Ray task's request. Bad arguments raise ``ConfigError``
    before anything runs; a log that fails is a failed row, never an exception.
    """
    from navlog.replay.session import pipeline_params

    if retries < 0:
        raise ConfigError(f"--retries {retries}: expected 0 or more")
    sources = collect_logs(logs, lists=lists, output=out)
    if params is None:
        params = pipeline_params(pipeline, overrides=overrides)
    out_root = str(out) if is_url(str(out)) else str(local_path(out).absolute())
    private = [a for a in [out_root, *(s.address for s in sources)] if private_to_process(a)]
    if executor is None:
        executor = make_executor(
            workers=1 if private and workers is None and not ray else workers,
            ray=ray,
            jobs=len(sources),
            cpus_per_log=cpus_per_log,
            memory_per_log=memory_per_log,
        )
    if private and not isinstance(executor, InProcess):
        executor.close()
        raise ConfigError(
            f"{private[0]}: this filesystem lives in one process's memory, which workers cannot see; "
            "use --workers 1, or storage every worker reads (a folder, s3://, gs://)"
        )
    created = not is_url(out_root) and not Path(out_root).exists()
    if not is_url(out_root):
        if Path(out_root).exists() and not Path(out_root).is_dir():
            raise ConfigError(f"{out}: is a file, not a folder; a fleet writes a folder per log there: choose a folder")
        try:
            Path(out_root).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise write_error(Path(out_root), exc) from None
    try:
        with nullcontext() if is_url(out_root) else hold_output(Path(out_root)):  # one fleet writes a folder at a time
            return _run(
                executor, sources, pipeline, params, out_root, remap, recover, force, metrics, retries, progress
            )
    except BaseException:  # Ctrl-C (or a defect): the logs done stay; a folder this call made and left empty goes
        if created:
            _remove_if_empty(Path(out_root))
        raise


def _remove_if_empty(folder: Path) -> None:
    """Remove ``folder`` when nothing complete is in it (it may hold only hidden partial outputs that a
    worker had not cleared yet)."""
    import shutil

    try:
        entries = list(folder.iterdir())
    except OSError:
        return
    if all(e.name.startswith(".") for e in entries):
        shutil.rmtree(folder, ignore_errors=True)


def _run(
    executor: Executor,
    sources: list[Any],
    pipeline: str,
    params: Any,
    out_root: str,
    remap: dict[str, str] | None,
    recover: bool,
    force: bool,
    metrics: bool,
    retries: int,
    progress: bool,
) -> FleetResult:
    jobs = [
        LogJob(s, pipeline, params, out_root, tuple(sorted((remap or {}).items())), recover, force, metrics)
        for s in sources
    ]
    start = time.perf_counter()
    with closing(FleetProgress(len(jobs), enabled=progress)) as bar:
        outcomes = run_jobs(
            executor,
            replay_log,
            jobs,
            retries=retries,
            retryable=lambda r: isinstance(r, LogResult) and r.transient,
            on_done=lambda i, r, n: bar.done(
                sources[i].name, isinstance(r, LogResult) and r.ok, r.reason if isinstance(r, LogResult | Lost) else ""
            ),
        )
    results = []
    for job, (outcome, attempts) in zip(jobs, outcomes, strict=True):
        if isinstance(outcome, Lost):
            outcome = LogResult(
                job.source.address, job.source.name, "failed", f"{job.source.address}: {outcome.reason}"
            )
        outcome.attempts = attempts
        results.append(outcome)
    document = summary_document(pipeline, results, version=__version__)
    files = _write_summary(out_root, document)
    return FleetResult(out_root, pipeline, executor.name, results, document, files, time.perf_counter() - start)


def _write_summary(out_root: str, document: dict[str, Any]) -> dict[str, str]:
    from navlog.replay.io.atomic import write_file

    texts = {"json": to_json(document), "csv": to_csv(document), "md": to_markdown(document)}
    files = {}
    for kind, name in SUMMARY_FILES.items():
        address = join(out_root, name)
        data = texts[kind].encode()
        if is_url(address):
            write_bytes(address, data)
        else:
            write_file(Path(address), data)
        files[kind] = address
    return files


def format_fleet(result: FleetResult) -> str:
    """What a fleet replay did, for a terminal: a line of counts, the table, where the summary is."""
    from navlog.replay.runtime.progress import format_table

    t = result.summary["totals"]
    headers, cells = summary_table(result.summary)
    head = (
        f"replayed {t['logs']} logs through '{result.pipeline}' into {result.out}/ on {result.executor} "
        f"in {result.wall_s:.1f} s wall: {t['ok']} ok ({t['cached']} up to date, reused), {t['failed']} failed"
    )
    table = format_table(headers, cells, align=["right" if h in NUMERIC_COLUMNS else "left" for h in headers])
    return f"{head}\n\n{table}\n\nsummary: " + ", ".join(result.files.values())
