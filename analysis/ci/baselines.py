"""Baselines: what a case's replay produced when it was accepted, small enough to review in a pull request.

One folder per case, ``BASELINES/SUITE/CASE/``, holding ``baseline.json``:
- ``provenance``: navlog version, pipeline, parameter hash, overrides, remap, the log's sha256 and its
  recipe (or file name);
- ``outputs``: every output file with its sha256, size, and the name it is stored under when kept.

Outputs a comparator reads (map_server maps with their image, plans.json, safety.json, metrics.json,
TUM, PCD) are kept beside it when they are at most 64 KiB, or gzip-compressed (``NAME.gz``, written
without a time stamp) when that fits; others (``replay.mcap``, large maps) are kept by hash only: other
bytes in them are reported as information (a PASS check with ``values["hash_only"]``, and a note of the
case), never a failure, since no tolerance can judge them; the case is judged by the outputs a
comparator reads and by its invariants (``ignore`` them in the suite to leave them out).
"""

from __future__ import annotations

import gzip
import json
import os
import shutil
import tempfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navlog.analysis.ci.result import CheckResult, Status
from navlog.analysis.diff.artifacts import compare_files, file_kind
from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import DiffTolerances
from navlog.errors import NavlogError
from navlog.replay.identity import sha256_file
from navlog.replay.io import json_text
from navlog.replay.io.atomic import replace_output

__all__ = [
    "BASELINE_FILE",
    "STORE_LIMIT",
    "Baseline",
    "compare_to_baseline",
    "read_baseline",
    "unused_baselines",
    "write_baseline",
]

BASELINE_FILE = "baseline.json"
SCHEMA = "navlog-baseline/1"
STORE_LIMIT = 64 * 1024  # bytes, after compression
IMAGE_SUFFIXES = (".pgm", ".png")
STATUS_OF = {
    Verdict.EQUAL: Status.PASS,
    Verdict.WITHIN: Status.PASS,
    Verdict.IMPROVED: Status.IMPROVED,
    Verdict.CHANGED: Status.FAIL,
    Verdict.REGRESSED: Status.FAIL,
}


@dataclass(frozen=True)
class Baseline:
    folder: Path
    data: dict[str, Any]

    @property
    def provenance(self) -> dict[str, Any]:
        return dict(self.data.get("provenance", {}))

    @property
    def navlog_version(self) -> str:
        return str(self.provenance.get("navlog_version", "?"))

    @property
    def outputs(self) -> dict[str, dict[str, Any]]:
        return dict(self.data.get("outputs", {}))

    def stored(self, name: str, into: Path) -> Path | None:
        """The kept copy of output ``name`` written into folder ``into`` (decompressed); None when only its
        hash is kept."""
        entry = self.outputs.get(name, {})
        kept = entry.get("stored")
        if not kept:
            return None
        src = self.folder / kept
        if not src.is_file():
            raise NavlogError(f"{src}: listed in {self.folder / BASELINE_FILE} but missing; rewrite it with --update")
        dst = into / name
        try:
            data = gzip.decompress(src.read_bytes()) if kept.endswith(".gz") else src.read_bytes()
        except (OSError, EOFError, zlib.error) as exc:  # (gzip.BadGzipFile is an OSError)
            raise NavlogError(f"{src}: cannot be read ({exc}); rewrite the baseline with --update") from None
        dst.write_bytes(data)
        return dst


def read_baseline(folder: Path) -> Baseline | None:
    """The baseline in ``folder``; None when there is none. A malformed one raises ``NavlogError``."""
    path = folder / BASELINE_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise NavlogError(f"{path}: not a readable baseline ({exc}); rewrite it with --update") from None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA or not isinstance(data.get("outputs"), dict):
        raise NavlogError(f"{path}: not a {SCHEMA} baseline; rewrite it with --update")
    for name, entry in data["outputs"].items():
        kept = entry.get("stored") if isinstance(entry, dict) else None
        for file_name in (name, kept) if kept else (name,):
            if not isinstance(file_name, str) or Path(file_name).name != file_name or file_name in ("", ".", ".."):
                raise NavlogError(
                    f"{path}: output name {file_name!r} is not a plain file name (it would be read or written "
                    "outside the baseline folder); rewrite the baseline with --update"
                )
    return Baseline(folder, data)


def _keep(name: str, src: Path, folder: Path) -> str | None:
    """Copy an output into the baseline folder when it is small (compressed if need be); the stored name."""
    if file_kind(Path(name)) is None and Path(name).suffix not in IMAGE_SUFFIXES:
        return None
    data = src.read_bytes()
    if len(data) <= STORE_LIMIT:
        (folder / name).write_bytes(data)
        return name
    packed = gzip.compress(data, compresslevel=9, mtime=0)
    if len(packed) <= STORE_LIMIT:
        (folder / f"{name}.gz").write_bytes(packed)
        return f"{name}.gz"
    return None


def write_baseline(folder: Path, outputs: Mapping[str, Path], provenance: Mapping[str, Any], *, label: str) -> None:
    """Replace the baseline in ``folder`` with ``outputs`` (name -> file) and ``provenance``."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = folder.with_name(f".{folder.name}.{os.getpid()}.partial")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        entries = {}
        for name, src in sorted(outputs.items()):
            entries[name] = {"sha256": sha256_file(src), "bytes": src.stat().st_size, "stored": _keep(name, src, tmp)}
        doc = {"schema": SCHEMA, "case": label, "provenance": dict(provenance), "outputs": entries}
        (tmp / BASELINE_FILE).write_text(json_text.dumps(doc, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        replace_output(tmp, folder)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def unused_baselines(root: Path, cases: Sequence[str]) -> list[str]:
    """Baseline folders under ``root`` (one suite's) that no case uses."""
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if p.is_dir() and not p.name.startswith(".") and p.name not in cases)


def _check(name: str, status: Status, message: str, values: dict[str, Any] | None = None) -> CheckResult:
    return CheckResult(name, "diff", status, message, values or {})


def _from_diff(c: Check) -> CheckResult:
    return _check(c.name, STATUS_OF[c.verdict], f"{c.verdict.value} ({c.kind}): {c.detail}", dict(c.values))


def compare_to_baseline(
    base: Baseline,
    current: Mapping[str, Path],
    tolerances: DiffTolerances,
    ignore: Sequence[str] = (),
    *,
    log_rounds_otherwise: bool = False,
) -> list[CheckResult]:
    """One check per output (and per moved metric of metrics.json): PASS when the bytes match or the
    comparator finds the change within tolerance, IMPROVED, or FAIL naming what moved. An output of
    which the baseline keeps only the hash cannot be judged: other bytes pass, with a message (and
    ``values["hash_only"]``) that says so.

    ``log_rounds_otherwise``: the replayed log is the baseline's recipe recorded on a machine that
    rounds otherwise (other bytes, the same layout); the messages of hash-only outputs say so."""
    want = {n: e["sha256"] for n, e in base.outputs.items()}
    have = {n: sha256_file(p) for n, p in current.items()}
    names = sorted((want.keys() | have.keys()) - set(ignore))
    stems = {Path(n).stem for n in names if file_kind(Path(n)) == "map"}
    images = {n for n in names if Path(n).suffix in IMAGE_SUFFIXES and Path(n).stem in stems}
    out: list[CheckResult] = []
    with tempfile.TemporaryDirectory(prefix="navlog-baseline-") as tmp:
        for name in names:
            if name in images:
                continue
            group = [name, *sorted(i for i in images if Path(i).stem == Path(name).stem)]
            missing = [n for n in group if n not in have]
            extra = [n for n in group if n not in want]
            if missing or extra:
                out += [_check(n, Status.FAIL, "in the baseline, not produced by this replay") for n in missing]
                out += [_check(n, Status.FAIL, "produced by this replay, not in the baseline") for n in extra]
                out += [_check(n, Status.PASS, "same bytes") for n in group if n not in missing + extra]
                continue
            moved = [n for n in group if want[n] != have[n]]
            if not moved:
                out += [_check(n, Status.PASS, "same bytes", {"sha256": have[n]}) for n in group]
                continue
            kept = [base.stored(n, Path(tmp)) for n in group]
            if file_kind(Path(name)) is None or any(k is None for k in kept):
                out += [_hash_only(n, want[n], have[n], log_rounds_otherwise) for n in group]
                continue
            found = compare_files(name, Path(tmp) / name, current[name], tolerances) or []
            if file_kind(Path(name)) == "metrics":
                moved_metrics = [c for c in found if c.verdict is not Verdict.EQUAL and c.name != name]
                out += [_from_diff(c) for c in moved_metrics] or [
                    _check(name, Status.PASS, "bytes differ, every value equal within tolerance")
                ]
                continue
            verdict = max((c.verdict for c in found), key=list(Verdict).index, default=Verdict.CHANGED)
            detail = "; ".join(c.detail for c in found)
            values = {k: v for c in found for k, v in c.values.items()}
            for n in group:
                if n in moved:
                    judged = "" if n == name else f" (judged with {name})"
                    out.append(_check(n, STATUS_OF[verdict], f"{verdict.value}{judged}: {detail}", values))
                else:
                    out.append(_check(n, Status.PASS, "same bytes", {"sha256": have[n]}))
    return out


def _hash_only(name: str, want: str, have: str, log_rounds_otherwise: bool = False) -> CheckResult:
    """An output the baseline keeps only by hash: other bytes are information (``values["hash_only"]``),
    not a failure; the case is judged by its other outputs, within their tolerances, and its invariants."""
    if want == have:
        return _check(name, Status.PASS, "same bytes", {"sha256": have})
    values = {"sha256": have, "baseline_sha256": want, "hash_only": True}
    if log_rounds_otherwise:
        why = (
            "the log was recorded with other bytes than the baseline's (the same layout: this machine rounds otherwise)"
        )
    else:
        why = "no tolerance applies to it; the case is judged by its other outputs and its checks"
    return _check(
        name,
        Status.PASS,
        f"bytes differ (sha256 {want[:12]} -> {have[:12]}), not judged: the baseline keeps only the hash of "
        f"{name}; {why}",
        values,
    )
