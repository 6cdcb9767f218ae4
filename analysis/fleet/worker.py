"""One log of a fleet, replayed where a worker runs it: ``replay_log(job) -> LogResult``.

The log's output folder is ``OUT/NAME`` and holds exactly what ``navlog replay LOG -o OUT/NAME``
writes; it is built aside (``OUT/.fleet/NAME.work``) and moved into place whole, and
``OUT/.fleet/NAME.json`` records what it was made from: the replay's identity
(``navlog.replay.identity``: the log's sha256, navlog's version, the pipeline, its parameters and
remaps; the key ``run_replay`` gives and the CI cache names its replays by) and the hash of its
manifest. When that record matches this job, the manifest lists the same input files (names, sizes,
sha256) and the outputs are there with their hashes, the log is not replayed again (``cached``)
unless ``force`` is set. A log that
cannot be replayed (truncated, corrupt, empty, missing the pipeline's topics) is a failed result
with its reason; ``replay_log`` never raises for it. An ``OSError`` (storage, network) is marked
``transient``: the fleet retries those, and lost workers, up to ``--retries`` times.

Everything here is picklable and runs the same in this process, a worker process or a Ray task.
"""

from __future__ import annotations

import hashlib
import json
import resource
import shutil
import tempfile
import time
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navlog.analysis.fleet.inputs import LogSource
from navlog.analysis.fleet.storage import download, filesystem, is_url, join, local_path, upload_folder, write_bytes
from navlog.errors import NavlogError
from navlog.replay.io.atomic import write_file
from navlog.replay.pipelines import pipeline_spec

__all__ = ["STATE", "LogJob", "LogResult", "job_identity", "replay_log"]

MANIFEST = "manifest.json"
STATE = ".fleet"  # OUT/.fleet/NAME.json: what the replay in OUT/NAME was made from


@dataclass(frozen=True)
class LogJob:
    """Everything one log's replay needs (picklable): the log, the pipeline and its parameters, the
    output root (a local folder or a URL) and the options of ``run_replay``."""

    source: LogSource
    pipeline: str
    params: Any
    out_root: str
    remap: tuple[tuple[str, str], ...] = ()
    recover: bool = False
    force: bool = False
    metrics: bool = True


@dataclass
class LogResult:
    """What one log's replay did. ``status`` is ``ok`` or ``failed`` (``reason`` says why)."""

    log: str
    name: str
    status: str
    reason: str = ""
    cached: bool = False
    duration_s: float = 0.0  # the log's own duration (sim time)
    messages: int = 0  # messages read from the log
    published: dict[str, int] = field(default_factory=dict)  # per output topic
    skipped: dict[str, int] = field(default_factory=dict)  # per reason
    truncated: bool = False
    outputs: dict[str, str] = field(default_factory=dict)  # file -> sha256
    metrics: dict[str, float] = field(default_factory=dict)
    metrics_error: str = ""
    transient: bool = False  # a failure worth retrying (storage, network)
    attempts: int = 1
    wall_s: float = 0.0  # the replay's wall time (not part of the summary: it varies run to run)
    peak_rss_mb: float = 0.0  # the peak resident memory of the process that ran it
    cpu_s: float = 0.0  # CPU time of the process that ran it, over the replay (all its threads)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def replay_log(job: LogJob) -> LogResult:
    """Replay one log (see the module docstring); failures are results, never exceptions."""
    start, cpu = time.perf_counter(), _cpu_s()
    try:
        result = _replay(job)
    except NavlogError as exc:
        result = _failed(job, str(exc))
    except OSError as exc:
        result = _failed(job, f"{type(exc).__name__}: {exc}", transient=True)
    except Exception as exc:  # a defect or an unreadable log: this log fails, the fleet goes on
        result = _failed(job, f"{type(exc).__name__}: {exc}")
    result.wall_s = time.perf_counter() - start
    result.cpu_s = _cpu_s() - cpu
    result.peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return result


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _failed(job: LogJob, reason: str, *, transient: bool = False) -> LogResult:
    return LogResult(job.source.address, job.source.name, "failed", reason, transient=transient)


def _replay(job: LogJob) -> LogResult:
    from navlog.replay.io.atomic import check_not_input, replace_output
    from navlog.replay.session import run_replay

    name = job.source.name
    out_url = join(job.out_root, name)
    state_url = join(job.out_root, f"{STATE}/{name}.json")
    remote = is_url(job.out_root)
    with ExitStack() as stack:
        scratch: list[Path] = []

        def temp() -> Path:
            if not scratch:
                scratch.append(Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="navlog-fleet-"))))
            return scratch[0]

        address = job.source.address
        log = download(address, temp() / "in" / Path(address.rstrip("/")).name) if is_url(address) else Path(address)
        manifest = None if job.force else _current_manifest(job, log, out_url, state_url)
        if manifest is not None:
            replay_dir = download(out_url, temp() / "out") if remote else local_path(out_url)
            return _result(job, manifest, log, replay_dir, cached=True)
        if remote:
            built = temp() / "out"
        else:
            out_dir = local_path(out_url)
            check_not_input(out_dir, [log], folder=True)  # (replaced whole below)
            if out_dir.is_dir() and any(out_dir.iterdir()) and not (out_dir / MANIFEST).is_file() and not job.force:
                raise NavlogError(
                    f"{out_dir}: the folder exists and holds no replay (no {MANIFEST}); "
                    "choose another output folder or pass --force to replace it"
                )
            # built in a folder of its own, moved into place whole: an interrupted or killed replay
            # leaves nothing under OUT/NAME, and the next run removes what it left in OUT/.fleet
            work = local_path(job.out_root) / STATE / f"{name}.work"
            shutil.rmtree(work, ignore_errors=True)
            work.mkdir(parents=True)
            stack.callback(shutil.rmtree, work, True)
            built = work / name
        res = run_replay(
            log,
            job.pipeline,
            built,
            params=job.params,
            remap=dict(job.remap),
            recover=job.recover,
            progress=False,
        )
        manifest_sha = hashlib.sha256((built / MANIFEST).read_bytes()).hexdigest()
        state = (
            json.dumps({"key": res.identity, "manifest_sha256": manifest_sha}, indent=2, sort_keys=True) + "\n"
        ).encode()
        if remote:
            upload_folder(built, out_url, last=MANIFEST)
            write_bytes(state_url, state)
            replay_dir = built
        else:
            replace_output(built, out_dir)
            write_file(local_path(state_url), state)
            replay_dir = out_dir
        return _result(job, res.manifest, log, replay_dir, cached=False)


def job_identity(job: LogJob, entries: list[dict[str, Any]], *, folder: bool) -> str:
    """The replay identity of ``job`` on the log whose ``input_entries`` are ``entries``."""
    from navlog.replay.identity import inputs_sha256, replay_identity

    return replay_identity(inputs_sha256(entries, folder=folder), job.pipeline, job.params, dict(job.remap))


def _read(url: str) -> bytes | None:
    if is_url(url):
        fs, path = filesystem(url)
        try:
            return bytes(fs.cat_file(path))
        except OSError:
            return None
    try:
        return local_path(url).read_bytes()
    except OSError:
        return None


def _current_manifest(job: LogJob, log: Path, out_url: str, state_url: str) -> dict[str, Any] | None:
    """The manifest of the replay in ``out_url`` when it is what this job would write: the fleet's
    record of it (``OUT/.fleet/NAME.json``) has this job's identity and the manifest's hash, the manifest
    lists these input files (names, sizes, sha256) and every output is there (locally: with its hash).
    The log is hashed only when there is such a record."""
    from navlog.replay.identity import input_entries, sha256_file

    state_bytes, manifest_bytes = _read(state_url), _read(join(out_url, MANIFEST))
    if state_bytes is None or manifest_bytes is None:
        return None
    try:
        state, manifest = json.loads(state_bytes), json.loads(manifest_bytes)
    except ValueError:
        return None
    if state.get("manifest_sha256") != hashlib.sha256(manifest_bytes).hexdigest():
        return None
    entries = input_entries(log)
    if state.get("key") != job_identity(job, entries, folder=log.is_dir()) or manifest.get("inputs") != entries:
        return None
    outputs = [o["file"] for o in manifest.get("outputs", {}).values()]
    if is_url(out_url):
        fs, path = filesystem(out_url)
        present = all(fs.exists(f"{path.rstrip('/')}/{f}") for f in outputs)
    else:
        folder = local_path(out_url)
        hashes = {o["file"]: o["sha256"] for o in manifest["outputs"].values()}
        present = all((folder / f).is_file() and sha256_file(folder / f) == hashes[f] for f in outputs)
    return manifest if present else None


def _result(job: LogJob, manifest: dict[str, Any], log: Path, replay_dir: Path, *, cached: bool) -> LogResult:
    info = manifest["log"]
    result = LogResult(
        job.source.address,
        job.source.name,
        "ok",
        cached=cached,
        duration_s=(info["end_ns"] - info["start_ns"]) / 1e9,
        messages=int(info["messages_read"]),
        published={str(k): int(v) for k, v in manifest["published"].items()},
        skipped={str(k): int(v) for k, v in manifest["skipped"].items()},
        truncated=bool(info["truncated"]),
        outputs={o["file"]: o["sha256"] for o in manifest["outputs"].values()},
    )
    if job.metrics and pipeline_spec(job.pipeline).scored_by_metrics:
        result.metrics, result.metrics_error = _metrics(log, replay_dir, job.recover)
    return result


def _metrics(log: Path, replay_dir: Path, recover: bool) -> tuple[dict[str, float], str]:
    """The numbers of ``compute_metrics`` (trajectory errors against the log's ground truth), flat; ``recover``:
    a truncated log's readable part, as its replay read it."""
    from navlog.analysis.diff.metric_values import flatten
    from navlog.analysis.metrics import compute_metrics

    try:
        metrics = compute_metrics(log, replay_dir, recover=recover)
    except NavlogError as exc:
        return {}, str(exc)
    metrics.pop("inputs", None)
    metrics.pop("parameters", None)
    flat = flatten(metrics)
    return {k: float(v) for k, v in sorted(flat.items()) if isinstance(v, int | float) and not isinstance(v, bool)}, ""
