"""The CI cache: golden logs recorded from recipes, world maps, and replays keyed by what made them.

Layout under the cache folder (default ``$NAVLOG_CACHE``, else ``$XDG_CACHE_HOME/navlog/ci``, else
``~/.cache/navlog/ci``):
- ``logs/WORLD-ROBOT-SCENARIO-sSEED-KEY.mcap``: a recipe recorded once per navlog version;
- ``maps/WORLD-mMARGIN-rRESOLUTION.yaml`` (+ .pgm): a world's obstacles as a map_server map;
- ``replays/KEY/``: a replay output folder; KEY is the replay's identity (``navlog.replay.identity``:
  log sha256, pipeline, parameter hash, remap, navlog version), so any change of code release, log or
  parameter replays again, and the key is the one a fleet's resume check and ``run_replay`` give.

Recording and world maps run the ``navlog`` command (``record``, ``world-map``) in a child process:
the analysis packages do not import the recorder. Everything is written under a temporary name and
moved into place, so parallel workers asking for the same entry never see half a file.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from navlog.analysis.ci.suite import Recipe, WorldMap
from navlog.errors import NavlogError
from navlog.replay.config import config_hash
from navlog.replay.io.atomic import replace_output
from navlog.version import __version__

__all__ = [
    "cached_log",
    "cached_replay",
    "cached_world_map",
    "default_cache_dir",
    "recipe_log_name",
]


def default_cache_dir() -> Path:
    if os.environ.get("NAVLOG_CACHE"):
        return Path(os.environ["NAVLOG_CACHE"]) / "ci"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "navlog" / "ci"


def log_layout_sha256(path: Path) -> str:
    """sha256 of an MCAP log's layout: each message's topic, schema, log time and size, in order. Two
    recordings of one recipe on machines whose floating point differs (NumPy's BLAS picks its kernels
    by CPU, and a kernel's sums round differently) have other bytes and the same layout; a change of
    the recorder, world, robot or scenario moves the layout too."""
    from mcap.reader import make_reader

    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
                name = schema.name if schema is not None else ""
                h.update(f"{channel.topic}\t{name}\t{message.log_time}\t{len(message.data)}\n".encode())
    except Exception as exc:  # a truncated or corrupt recording: named, not a traceback
        raise NavlogError(f"{path}: cannot read the log's messages ({exc})") from exc
    return h.hexdigest()


def recipe_log_name(recipe: Recipe) -> str:
    key = config_hash({"recipe": recipe.to_dict(), "navlog_version": __version__})[:12]
    noise = "" if recipe.noise else "-nonoise"
    return f"{recipe.world}-{recipe.robot}-{recipe.scenario}-s{recipe.seed}{noise}-{key}.mcap"


def _navlog(args: list[str], what: str) -> None:
    """Run the ``navlog`` command line in a child process; its error becomes a ``NavlogError``."""
    proc = subprocess.run([sys.executable, "-m", "navlog.cli", "-q", *args], capture_output=True, text=True)
    if proc.returncode != 0:
        lines = [ln for ln in (proc.stderr or proc.stdout).splitlines() if ln.strip()]
        raise NavlogError(f"{what}: {lines[-1] if lines else f'navlog exited with {proc.returncode}'}")


def _partial(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def cached_log(recipe: Recipe, cache_dir: Path) -> tuple[Path, bool]:
    """The recipe's log in the cache (recorded when missing) and whether it was there already."""
    out = cache_dir / "logs" / recipe_log_name(recipe)
    if out.is_file():
        return out, True
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = _partial(out).with_suffix(".mcap")
    args = ["record", "--world", recipe.world, "--robot", recipe.robot, "--scenario", recipe.scenario]
    args += ["--seed", str(recipe.seed), *([] if recipe.noise else ["--no-noise"]), "-o", str(tmp), "--force"]
    try:
        _navlog(args, f"recording {recipe.world}/{recipe.robot}/{recipe.scenario}")
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out, False


def cached_world_map(spec: WorldMap, cache_dir: Path) -> Path:
    """The world's map_server map in the cache (written when missing)."""
    resolution = 0.05 if spec.resolution is None else spec.resolution
    out = cache_dir / "maps" / f"{spec.world}-m{spec.margin:g}-r{resolution:g}.yaml"
    if out.is_file() and out.with_suffix(".pgm").is_file():
        return out
    tmp_dir = cache_dir / "maps" / f".{out.stem}.{os.getpid()}.partial"
    shutil.rmtree(tmp_dir, ignore_errors=True)
    tmp_dir.mkdir(parents=True)
    try:
        args = ["world-map", spec.world, "--margin", str(spec.margin), "--resolution", str(resolution)]
        _navlog([*args, "-o", str(tmp_dir / out.name)], f"world map of {spec.world}")
        os.replace(tmp_dir / out.with_suffix(".pgm").name, out.with_suffix(".pgm"))
        os.replace(tmp_dir / out.name, out)
    finally:
        shutil.rmtree(tmp_dir, ignore_errors=True)
    return out


@contextmanager
def cached_replay(
    log: Path, pipeline: str, params: Any, remap: dict[str, str], key: str, cache_dir: Path, *, fresh: bool = False
) -> Iterator[tuple[Path, bool]]:
    """The replay folder for ``key`` (replayed when missing, or always with ``fresh``) and whether it was
    cached, to be read within the ``with`` block.

    Two workers may replay the same key at once (two cases of a suite with the same log and parameters), and
    a replay in place may be being read by another case: no replay in place is ever replaced or deleted. The
    first replay put in place stays (the key names the same bytes). A fresh one is read from its own folder
    and put in place at the end of the block only where none is; otherwise it is deleted."""
    from navlog.replay.session import run_replay

    out = cache_dir / "replays" / key
    if not fresh and (out / "manifest.json").is_file():
        yield out, True
        return
    tmp = _partial(out)
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        run_replay(log, pipeline, tmp, params=params, remap=remap, progress=False)
        if fresh:
            yield tmp, False
        if not (out / "manifest.json").is_file():
            try:  # a folder a killed run left without its manifest is moved aside
                replace_output(tmp, out)
            except OSError:  # another worker put its own there between the two renames: the same bytes
                pass
        if not fresh:
            yield out, False
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
