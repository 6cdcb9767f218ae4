"""``diff(a, b)``: what moved between two replay output folders, or two logs.

Replay folders (``navlog replay ... -o OUT/``) are compared through their ``manifest.json``: outputs
whose sha256 match are EQUAL without being read; the others go to the comparator of their kind
(``artifacts``: map_server maps with their image, PCD maps, TUM trajectories, plans.json) and
``replay.mcap`` to the topic-by-topic log diff (``logs``); a ``metrics.json`` beside the outputs in
both folders is compared by metric direction. Logs (anything ``open_log`` reads) are compared topic
by topic. Two files of a kind the artifact comparators read (map .yaml, .pcd, .tum, plans.json,
metrics .json) are compared directly. Differences in the manifests' parameters, inputs and navlog
version are reported as notes.

``ignore``: ``/topic`` drops a topic, ``/topic.field.path`` a field of its messages (from the first
divergence and the field comparator), a file name (``trajectory.tum``) drops an output.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from navlog.analysis.diff.artifacts import compare_files, compare_metrics_files, file_kind, read_json
from navlog.analysis.diff.logs import compare_logs
from navlog.analysis.diff.metric_values import flatten
from navlog.analysis.diff.result import Check, DiffReport, Divergence, Verdict
from navlog.analysis.diff.tolerances import DEFAULT_TOLERANCES, DiffTolerances
from navlog.errors import NavlogError
from navlog.replay.io.mcap_reader import MCAP_MAGIC

__all__ = ["DiffInputError", "diff", "input_kind"]

MANIFEST = "manifest.json"
METRICS = "metrics.json"
IMAGE_SUFFIXES = (".pgm", ".png")


class DiffInputError(NavlogError):
    """A or B is neither a replay output folder nor a log (or the two are of different kinds)."""


def input_kind(path: Path) -> str:
    """``replay`` (a folder with manifest.json), ``log`` (.mcap, .db3, rosbag2 folder) or ``file`` (a
    file the artifact comparators read); anything else raises ``DiffInputError`` naming the path."""
    if not path.exists():
        raise DiffInputError(f"{path}: no such file or folder")
    if path.is_dir():
        if (path / MANIFEST).is_file():
            return "replay"
        if (path / "metadata.yaml").is_file():
            return "log"
        if (path / "replay.mcap").is_file():
            raise DiffInputError(f"{path}: replay output folder without {MANIFEST}; replay again with `navlog replay`")
        raise DiffInputError(
            f"{path}: neither a replay output folder (no {MANIFEST}) nor a rosbag2 log (no metadata.yaml)"
        )
    if path.suffix in (".mcap", ".db3"):
        return "log"
    if file_kind(path) is not None:
        return "file"
    with open(path, "rb") as f:
        if f.read(len(MCAP_MAGIC)) == MCAP_MAGIC:
            return "log"
    raise DiffInputError(
        f"{path}: not a log (.mcap, .db3, rosbag2 folder), a replay output folder, or a map .yaml, .pcd, .tum or .json"
    )


def diff(
    a: Path | str, b: Path | str, *, tolerances: DiffTolerances = DEFAULT_TOLERANCES, ignore: Sequence[str] = ()
) -> DiffReport:
    """Compare B against A; see the module docstring. Bad input raises a ``NavlogError`` naming the path."""
    pa, pb = Path(a), Path(b)
    ka, kb = input_kind(pa), input_kind(pb)
    if ka != kb:
        raise DiffInputError(f"cannot compare {pa} ({_KIND_TEXT[ka]}) with {pb} ({_KIND_TEXT[kb]})")
    notes: list[str] = []
    divergence: Divergence | None = None
    ignored: list[str] = []
    if ka == "replay":
        checks, divergence, ignored, notes = _diff_replays(pa, pb, tolerances, ignore)
    elif ka == "log":
        checks, divergence, ignored = compare_logs(pa, pb, tolerances, ignore)
    else:
        if file_kind(pa) != file_kind(pb):
            raise DiffInputError(f"cannot compare {pa} with {pb}: files of different kinds")
        checks = compare_files(pa.name, pa, pb, tolerances) or []
    return DiffReport(
        a=str(pa),
        b=str(pb),
        kind=ka,
        checks=tuple(checks),
        first_divergence=divergence,
        notes=tuple(notes),
        ignored=tuple(ignored),
        tolerances=tolerances.to_dict(),
    )


_KIND_TEXT = {"replay": "a replay output folder", "log": "a log", "file": "a file"}


def _manifest(folder: Path) -> dict[str, Any]:
    path = folder / MANIFEST
    data = read_json(path)
    outputs = data.get("outputs") if isinstance(data, dict) else None
    if not isinstance(outputs, dict) or not all(
        isinstance(o, dict) and "file" in o and "sha256" in o for o in outputs.values()
    ):
        raise DiffInputError(f"{path}: not a navlog replay manifest (no 'outputs' with file and sha256)")
    for o in outputs.values():
        if not (folder / o["file"]).is_file():
            raise DiffInputError(f"{folder / o['file']}: listed in {path} but missing")
    return data


def _diff_replays(
    a: Path, b: Path, tol: DiffTolerances, ignore: Sequence[str]
) -> tuple[list[Check], Divergence | None, list[str], list[str]]:
    ma, mb = _manifest(a), _manifest(b)
    files_a = {o["file"]: o["sha256"] for o in ma["outputs"].values()}
    files_b = {o["file"]: o["sha256"] for o in mb["outputs"].values()}
    ignored = sorted(f for f in files_a.keys() | files_b.keys() if f in ignore)
    everything = files_a.keys() | files_b.keys()
    # a map image belongs to the map .yaml of its stem: the grid check covers both (ignoring one ignores both)
    yamls = {Path(n).stem for n in everything if n.endswith(".yaml")}
    images = {n for n in everything if Path(n).suffix in IMAGE_SUFFIXES and Path(n).stem in yamls}
    names = sorted(everything - set(ignored))
    checks: list[Check] = []
    divergence: Divergence | None = None
    for name in names:
        if name in images:
            continue
        ha, hb = files_a.get(name), files_b.get(name)
        if ha is None or hb is None:
            side = "A" if hb is None else "B"
            checks.append(Check(name, "file", Verdict.CHANGED, {}, {}, f"output only in {side}"))
            continue
        parts = [name] + [i for i in images if Path(i).stem == Path(name).stem and name.endswith(".yaml")]
        if all(files_a.get(p) == files_b.get(p) for p in parts):
            checks.append(Check(name, "bytes", Verdict.EQUAL, {"sha256": ha}, {}, "same bytes"))
            continue
        if name.endswith(".mcap"):
            topic_checks, divergence, topics_ignored = compare_logs(a / name, b / name, tol, ignore)
            checks.extend(topic_checks)
            ignored.extend(topics_ignored)
            continue
        found = compare_files(name, a / name, b / name, tol)
        checks.extend(found if found is not None else [Check(name, "file", Verdict.CHANGED, {}, {}, "bytes differ")])
    if METRICS not in names and (a / METRICS).is_file() and (b / METRICS).is_file():
        checks.extend(compare_metrics_files(METRICS, a / METRICS, b / METRICS, tol))
    return checks, divergence, ignored, _manifest_notes(ma, mb)


def _manifest_notes(ma: dict[str, Any], mb: dict[str, Any]) -> list[str]:
    notes: list[str] = []
    for key in ("navlog_version", "pipeline"):
        if ma.get(key) != mb.get(key):
            notes.append(f"{key}: {ma.get(key)} -> {mb.get(key)}")
    if [i.get("sha256") for i in ma.get("inputs", [])] != [i.get("sha256") for i in mb.get("inputs", [])]:
        notes.append("inputs: the two replays read different logs")
    pa, pb = flatten(ma.get("parameters", {})), flatten(mb.get("parameters", {}))
    for k in sorted(pa.keys() | pb.keys()):
        if pa.get(k) != pb.get(k):
            notes.append(f"parameter {k}: {pa.get(k)!r} -> {pb.get(k)!r}")
    return notes
