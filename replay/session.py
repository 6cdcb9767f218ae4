"""Replaying a log through a pipeline: the one function behind ``navlog replay``.

The log is streamed (only the topics the pipeline reads) through the executor into the pipeline's
nodes; their outputs go to ``OUT/replay.mcap``; then the pipeline writes its files and a manifest
records the input hashes, every parameter, the output hashes and every skipped input with its
reason. Everything is written into a temporary folder first and moved into place at the end, so
a failed replay leaves nothing half-written.
"""

from __future__ import annotations

import logging
import shutil
import threading
import time
from collections.abc import Iterator, Sequence, Set
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navlog.errors import ConfigError, NavlogError
from navlog.replay.config import apply_overrides, find_config, from_mapping, load_config, suggest, to_mapping
from navlog.replay.identity import input_entries, inputs_sha256, replay_identity, sha256_file
from navlog.replay.io import cdr_decode, json_text
from navlog.replay.io.atomic import WriteError, check_not_input, hold_output, remove_stale, replace_output, write_error
from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.reader import MAX_LOG_TIME_JUMP_NS, LogReader
from navlog.replay.pipelines import pipeline_spec
from navlog.replay.runtime.executor import Envelope, Executor, Published
from navlog.replay.runtime.heap import HeapTrim, steady_heap
from navlog.replay.runtime.pipeline import Pipeline
from navlog.replay.runtime.progress import Progress, format_table
from navlog.version import __version__

logger = logging.getLogger("navlog")


def pipeline_params(name: str, params_file: Path | None = None, overrides: Sequence[str] = ()) -> Any:
    """The pipeline's parameters: its YAML (config/pipelines/NAME.yaml or ``params_file``) plus overrides.

    A pipeline that takes a foreign parameter file (the planner takes a Nav2 ``nav2_params.yaml``)
    names the key that holds its path (``PipelineSpec.params_file_key``); ``params_file`` then fills
    that key and the pipeline's own YAML still supplies the rest. A pipeline that reads the file of the
    ROS tool it stands in for (``PipelineSpec.foreign_overrides``: slam_toolbox's for the mapping
    pipeline) takes its values over its own YAML's, and ``overrides`` over both.
    """
    spec = pipeline_spec(name)
    key = spec.params_file_key
    if params_file is not None and key:
        overrides = [f"{key}={Path(params_file).resolve()}", *overrides]
        params_file = None
    foreign = spec.foreign_overrides(Path(params_file)) if params_file is not None else None
    if foreign is not None:  # a ROS tool's file (slam_toolbox's): its values, then the command line's
        overrides = [*foreign, *overrides]
        params_file = None
    path = Path(params_file) if params_file is not None else find_config("pipelines", name)
    if path is not None:
        return load_config(spec.params_class, path, overrides)
    return from_mapping(spec.params_class, apply_overrides({}, overrides))


def parse_remaps(items: Sequence[str]) -> dict[str, str]:
    """``PIPELINE_TOPIC=LOG_TOPIC`` pairs: read LOG_TOPIC where the pipeline expects PIPELINE_TOPIC."""
    out = {}
    for item in items:
        if "=" not in item:
            raise ConfigError(f"--remap '{item}': expected PIPELINE_TOPIC=LOG_TOPIC, e.g. /scan=/stable_scan")
        a, b = item.split("=", 1)
        out[a.strip()] = b.strip()
    return out


def _hash_inputs(log: Path) -> Future:
    """The manifest's input entries, computed in a background thread while the log replays (hashing
    releases the GIL, so the input's digest costs no replay time on a second core). The thread is a
    daemon: an interrupted replay does not wait for it."""
    future: Future = Future()

    def work() -> None:
        try:
            future.set_result(input_entries(log))
        except BaseException as exc:  # raised by ``result()`` in the replaying thread
            future.set_exception(exc)

    threading.Thread(target=work, name="navlog-hash", daemon=True).start()
    return future


_UNSET = object()


class _OutputSink:
    """Writes the pipeline's output topics (only) to the replay log, and on its ``published`` topics the messages
    its nodes published (not the log's); the types with a fast CDR encoder (``cdr_decode.encoder``: Twist) are
    serialized by it, the same bytes."""

    def __init__(self, writer: McapLogWriter, topics: Set[str], published: Set[str] = frozenset()) -> None:
        self.writer, self.topics, self.published = writer, topics, published
        self._encoders: dict[str, Any] = {}  # type name -> its fast encoder or None

    def write(self, env: Envelope) -> None:
        if env.topic not in self.topics and not (env.topic in self.published and isinstance(env, Published)):
            return
        encode = self._encoders.get(env.typename, _UNSET)
        if encode is _UNSET:
            encode = self._encoders[env.typename] = cdr_decode.encoder(env.typename)
        if encode is None or isinstance(env.msg, bytes | bytearray | memoryview):
            self.writer.write(env)
        else:
            self.writer.write_raw(env.topic, env.typename, env.time_ns, encode(env.msg))


@dataclass
class ReplayResult:
    out_dir: Path
    manifest: dict
    wall_s: float
    identity: str = ""  # the replay's key (``navlog.replay.identity``): what the CI cache and a fleet name it by

    @property
    def log_s(self) -> float:
        log = self.manifest["log"]
        return (log["end_ns"] - log["start_ns"]) / 1e9


def run_replay(
    log: Path | str,
    pipeline: str,
    out_dir: Path | str,
    *,
    params: Any = None,
    overrides: Sequence[str] = (),
    remap: dict[str, str] | None = None,
    recover: bool = False,
    force: bool = False,
    progress: bool = True,
) -> ReplayResult:
    log, out_dir = Path(log), Path(out_dir)
    steady_heap()  # the peak stays flat over a long log (navlog.replay.runtime.heap)
    spec = pipeline_spec(pipeline)
    if params is None:
        params = pipeline_params(pipeline, overrides=overrides)
    remap = dict(remap or {})
    asked = params  # the parameters given: the replay's identity (``auto`` values settled below follow from the log)
    check_not_input(out_dir, [log], folder=True)
    if out_dir.exists() and not out_dir.is_dir():
        raise NavlogError(f"{out_dir}: output is a file, not a folder; choose a folder name for -o")
    if out_dir.exists() and any(out_dir.iterdir()) and not force:
        raise NavlogError(f"{out_dir}: output folder exists and is not empty; choose another or pass --force")
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(out_dir.parent, exc) from None
    with hold_output(out_dir):  # one run writes out_dir at a time
        with open_log(log, recover=recover) as reader:
            to_log = dict(remap)  # pipeline topic -> log topic, for remapped topics only
            log_to = {v: k for k, v in remap.items()}
            logical_topics = {log_to.get(t, t) for t in reader.topics}
            params = spec.settle(params, reader, log_to)  # `auto` parameters decided from the log's content
            pipe = spec.build(params, logical_topics)
            missing = [t for t in pipe.inputs if to_log.get(t, t) not in reader.topics]
            have = ", ".join(f"{t.name} ({t.typename})" for t in sorted(reader.topics.values(), key=lambda t: t.name))
            remapped = [t for t in missing if t in to_log]
            if remapped:
                which = ", ".join(f"{to_log[t]} (read as {t}, --remap {t}={to_log[t]})" for t in remapped)
                raise NavlogError(
                    f"{log}: the remapped topic {which} is not in the log. The log has: {have}. "
                    "Remap to one of these topics."
                )
            if missing:
                raise NavlogError(
                    f"{log}: pipeline '{pipeline}' needs {', '.join(pipe.inputs)}; missing {', '.join(missing)}. "
                    f"The log has: {have}. Map a topic with --remap PIPELINE_TOPIC=LOG_TOPIC "
                    f"(e.g. --remap {missing[0]}=/other_topic), or change the pipeline parameters with --set."
                )
            _check_remaps(log, pipeline, pipe, reader, remap)
            wanted = [to_log.get(t, t) for t in pipe.inputs + pipe.optional_inputs if to_log.get(t, t) in reader.topics]
            if reader.unknown_types:
                logger.warning(
                    "%s: skipping topics of types without a definition: %s", reader.path, reader.unknown_listed
                )
            remove_stale(out_dir)  # an old output a killed run had moved aside comes back
            tmp = out_dir.parent / f".{out_dir.name}.partial"
            shutil.rmtree(tmp, ignore_errors=True)
            tmp.mkdir(parents=True)
            try:
                inputs = _hash_inputs(log)
                result = _run(reader, pipe, wanted, log_to, tmp, progress)
                empty = pipe.nothing_produced()
                if empty is not None:
                    skipped = pipe.skipped()
                    why = "; ".join(f"{reason} x{n}" for reason, n in sorted(skipped.items())) or "no input was skipped"
                    raise NavlogError(
                        f"{log}: pipeline '{pipeline}' produced nothing: {empty}. Skipped inputs: {why}. "
                        f"Check the topics it reads ({', '.join(pipe.inputs + pipe.optional_inputs)}) with "
                        f"`navlog info {log}`: a missing /tf_static or a remapped TF topic leaves every input without a pose."
                    )
                entries = inputs.result()
                identity = replay_identity(inputs_sha256(entries, folder=log.is_dir()), pipeline, asked, remap)
                manifest = _manifest(entries, reader, pipeline, params, pipe, result, tmp, remap)
                (tmp / "manifest.json").write_text(json_text.dumps(manifest, indent=2, sort_keys=True) + "\n")
            except WriteError as exc:  # a file it could not write: named where the user asked for it
                shutil.rmtree(tmp, ignore_errors=True)
                raise exc.moved(tmp, out_dir) from None
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)
                raise
        replace_output(tmp, out_dir)
    return ReplayResult(out_dir, manifest, result["wall_s"], identity)


def format_summary(log: Path | str, res: ReplayResult) -> str:
    """What a replay did: the log, the speed, the pipeline's facts, the outputs with their hashes, the skips."""
    m = res.manifest
    lines = [
        f"replayed {log} through '{m['pipeline']}' into {res.out_dir}/",
        f"log {res.log_s:.2f} s in {res.wall_s:.2f} s wall ({res.log_s / max(res.wall_s, 1e-9):.1f}x real time), "
        f"{m['log']['messages_read']} messages read"
        + (" (truncated log: readable part only)" if m["log"]["truncated"] else ""),
    ]
    tables = []
    if m["pipeline_info"]:
        tables.append(format_table(("pipeline", "value"), list(m["pipeline_info"].items())))
    tables.append(format_table(("output", "sha256"), [(o["file"], o["sha256"][:16]) for o in m["outputs"].values()]))
    if m["skipped"]:
        rows = [(n, reason) for reason, n in m["skipped"].items()]
        tables.append(format_table(("count", "reason"), rows, title="skipped inputs", align=("right", "left")))
    return "\n\n".join(["\n".join(lines), *tables])


def _check_remaps(log: Path, name: str, pipe: Pipeline, reader: LogReader, remap: dict[str, str]) -> None:
    """Every ``--remap PIPELINE_TOPIC=LOG_TOPIC`` names a topic the pipeline reads and one the log has."""
    reads = pipe.inputs + pipe.optional_inputs
    for ours, theirs in sorted(remap.items()):
        if ours not in reads:
            raise ConfigError(
                f"--remap {ours}={theirs}: pipeline '{name}' reads no topic {ours}{suggest(ours, reads)}; "
                f"it reads {', '.join(reads)}"
            )
        if theirs not in reader.topics:
            raise ConfigError(
                f"--remap {ours}={theirs}: {log} has no topic {theirs}{suggest(theirs, reader.topics)}; "
                f"its topics: {', '.join(sorted(reader.topics))}"
            )


def _check_types(log: Path, ex: Executor, reader: LogReader, wanted: list[str], log_to: dict[str, str]) -> None:
    """The log's topics carry the message types the pipeline's nodes read (after remapping)."""
    expected = ex.subscribed_types()
    for log_topic in wanted:
        ours = log_to.get(log_topic, log_topic)
        types = expected.get(ours)
        have = reader.topics[log_topic].typename
        if not types or have in types:
            continue
        same = sorted(t.name for t in reader.topics.values() if t.typename in types)
        where = f"--remap {ours}={log_topic}: {log_topic}" if ours != log_topic else f"{log}: {log_topic}"
        raise ConfigError(
            f"{where} carries {have}, but the pipeline reads {ours} as {' or '.join(types)}; "
            + (f"topics of that type in the log: {', '.join(same)}" if same else "the log has no topic of that type")
        )


def _run(
    reader: LogReader, pipe: Pipeline, wanted: list[str], log_to: dict[str, str], tmp: Path, progress: bool
) -> dict:
    ex = Executor(start_ns=reader.start_ns)

    last_stamp: dict[str, int] = {}
    backwards: dict[str, int] = {}

    def stream(light: set[str]) -> Iterator[Envelope]:
        for env in reader.messages(wanted, light=light):
            topic = log_to.get(env.topic, env.topic)
            header = getattr(env.msg, "header", None)
            if header is not None:
                stamp = header.stamp.sec * 1_000_000_000 + header.stamp.nanosec
                last = last_stamp.get(topic)
                if last is None or stamp >= last:
                    last_stamp[topic] = stamp
                else:
                    backwards[topic] = backwards.get(topic, 0) + 1
            yield env if topic == env.topic else Envelope(topic, env.typename, env.time_ns, env.msg)

    for node in pipe.nodes:
        ex.add_node(node)
    # the log's topics whose every subscriber takes their light form (TF buffers: /tf as numbers, no objects)
    to_log = {ours: theirs for theirs, ours in log_to.items()}
    ex.add_source(stream({to_log.get(t, t) for t in ex.light_topics()}))
    _check_types(reader.path, ex, reader, wanted, log_to)
    first = ex.next_source_ns()
    if first is not None and first - reader.start_ns > MAX_LOG_TIME_JUMP_NS:
        # the reader kept a later run than the log's first messages (their log times corrupt): the replay
        # starts at the first message it delivers, not after years of timers firing on nothing
        ex.begin_at(first)
    start = time.perf_counter()
    t0 = ex.now
    with (
        Progress(reader.duration_ns / 1e9, f"replay {pipe.name}", "log s", enabled=progress) as bar,
        McapLogWriter(
            tmp / "replay.mcap",
            metadata={"navlog": {"navlog_version": __version__, "pipeline": pipe.name}},
            background=True,  # serialising, compressing and writing on the second core (the same bytes)
        ) as writer,
    ):
        ex.add_sink(_OutputSink(writer, set(pipe.outputs), set(pipe.published_outputs)))
        chunk = 1_000_000_000
        t = t0
        trim = HeapTrim()  # the resident size follows what is in use (navlog.replay.runtime.heap)
        while True:
            t += chunk
            ex.run(until_ns=t)
            bar.update((ex.now - t0) / 1e9)
            trim()
            if not ex.sources_pending:
                break
        ex.finish()
    artifacts = pipe.write_artifacts(tmp)
    return {"wall_s": time.perf_counter() - start, "stats": ex.stats, "artifacts": artifacts, "backwards": backwards}


def _as_decided(params: dict, info: dict[str, str]) -> dict:
    """The parameters as the nodes ran with them: a top-level parameter the pipeline decides and hands
    down (``pose_source: auto`` -> the mapper's ``occupancy.pose_source``) shows, where nested, the
    value decided (``pipe.info``); the top level keeps what was asked for."""
    decided = {k: v for k, v in info.items() if k in params}

    def walk(d: dict) -> dict:
        return {k: walk(v) if isinstance(v, dict) else decided.get(k, v) for k, v in d.items()}

    return {k: walk(v) if isinstance(v, dict) else v for k, v in params.items()}


def _manifest(
    inputs: list[dict], reader: LogReader, name: str, params: Any, pipe, result: dict, tmp: Path, remap: dict
) -> dict:
    stats = result["stats"]
    files = {"replay_mcap": tmp / "replay.mcap", **result["artifacts"]}
    skipped = {f"log: {k}": v for k, v in sorted(reader.report.skipped.items())}
    skipped.update({k: v for k, v in sorted(pipe.skipped().items())})
    for t in sorted(reader.topics.values(), key=lambda t: t.name):  # whole topics whose schema was refused
        if not t.known and t.why:
            skipped[f"log: {t.name} messages ({t.why})"] = t.count
    if stats.out_of_order:
        skipped["log: messages with out-of-order timestamps (delivered in arrival order)"] = stats.out_of_order
    for topic, n in sorted(result["backwards"].items()):
        skipped[f"log: {topic} header stamps going backwards (replayed in log order)"] = n
    return {
        "navlog_version": __version__,
        "pipeline": name,
        "parameters": _as_decided(to_mapping(params), pipe.info),
        "pipeline_info": dict(sorted(pipe.info.items())),
        "remap": dict(sorted(remap.items())),
        "inputs": inputs,
        "log": {
            "start_ns": reader.start_ns,
            "end_ns": reader.end_ns,
            "topics_read": sorted({e for e in pipe.inputs + pipe.optional_inputs}),
            "messages_read": reader.report.read,
            "truncated": reader.report.truncated,
            "unknown_types": dict(sorted(reader.unknown_types.items())),
        },
        "outputs": {k: {"file": p.name, "sha256": sha256_file(p)} for k, p in sorted(files.items())},
        "published": dict(sorted((t, n) for t, n in stats.published.items())),
        "skipped": skipped,
    }
