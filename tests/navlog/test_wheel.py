"""The wheel, installed in a fresh virtual environment and run from an empty folder.

The wheel is built from a copy of the sources (no stale build folder can add to it), without
build isolation (nothing is downloaded). The fresh environment gets the wheel alone (``--no-deps``);
its dependencies come from this environment's site-packages through a ``.pth`` file, which adds
the folder to ``sys.path`` after the environment's own (it does not run this environment's
editable-install hook), so ``import navlog`` finds the installed copy and nothing of the checkout.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from importlib.metadata import version
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())

pytestmark = [pytest.mark.wheel, pytest.mark.slow]


def run(args: list[str | Path], cwd: Path, env: dict[str, str] | None = None, timeout: float = 300) -> str:
    res = subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert res.returncode == 0, f"{' '.join(map(str, args))} exited {res.returncode}\n{res.stdout}\n{res.stderr}"
    return res.stdout


def source_files() -> dict[str, Path]:
    """Path in the wheel -> file in the checkout, for every module and shipped YAML file."""
    out = {}
    for name, folder in PYPROJECT["tool"]["setuptools"]["package-dir"].items():
        root = REPO / folder
        for path in sorted(root.rglob("*")):
            if path.suffix in (".py", ".yaml") and "__pycache__" not in path.parts:
                out["/".join((*name.split("."), *path.relative_to(root).parts))] = path
    return out


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if int(version("setuptools").split(".")[0]) < 77:
        pytest.fail("building the wheel needs setuptools >= 77: run scripts/setup.sh (it installs .[test])")
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, src / name)
    for folder in set(PYPROJECT["tool"]["setuptools"]["package-dir"].values()):
        shutil.copytree(REPO / folder, src / folder, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    dist = tmp / "dist"
    run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-w", dist, src],
        cwd=tmp,
    )
    (whl,) = dist.glob("navlog-*.whl")
    return whl


@pytest.fixture(scope="module")
def venv(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment with the wheel installed and this environment's packages visible."""
    env_dir = tmp_path_factory.mktemp("venv") / "env"
    run([sys.executable, "-m", "venv", "--without-pip", env_dir], cwd=env_dir.parent)
    py = env_dir / "bin" / "python"
    run([sys.executable, "-m", "pip", "--python", py, "install", "--no-deps", "--no-index", "-q", wheel], cwd=env_dir)
    site = Path(run([py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"], cwd=env_dir).strip())
    (site / "navlog-test-dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    return env_dir


@pytest.fixture
def user_env(tmp_path: Path) -> dict[str, str]:
    """The environment of a user's shell: nothing points at the checkout."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NAVLOG_CONFIG_PATH", "VIRTUAL_ENV")}
    env["HOME"] = str(tmp_path / "home")
    return env


def test_wheel_holds_one_top_level_name_and_every_file(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        (dist_info,) = {n.split("/")[0] for n in names if n.split("/")[0].endswith(".dist-info")}
        assert zf.read(f"{dist_info}/top_level.txt").decode().split() == ["navlog"]
        entry_points = zf.read(f"{dist_info}/entry_points.txt").decode()
    assert [n for n in names if not n.startswith(("navlog/", f"{dist_info}/"))] == []
    assert "navlog = navlog.cli:main" in entry_points
    for name in (
        "navlog/py.typed",
        "navlog/config/worlds/indoor_room.yaml",
        "navlog/config/robots/go2.yaml",
        "navlog/config/scenarios/teleop.yaml",
        "navlog/config/pipelines/mapping.yaml",
        "navlog/replay/io/__init__.py",
        "navlog/analysis/__init__.py",
        "navlog/recorder/record.py",
    ):
        assert name in names
    missing = sorted(set(source_files()) - set(names))
    assert missing == [], "not in the wheel (missing from [tool.setuptools] packages?):\n" + "\n".join(missing)


def test_installed_navlog_runs_outside_the_checkout(venv: Path, tmp_path: Path, user_env: dict[str, str]) -> None:
    bin_dir = venv / "bin"
    work = tmp_path / "work"
    work.mkdir()

    where = run(
        [
            bin_dir / "python",
            "-c",
            "import navlog, navlog.replay; print(navlog.__file__); print(navlog.replay.__file__)",
        ],
        work,
        user_env,
    ).split()
    assert all(Path(p).is_relative_to(venv) for p in where), where
    run([bin_dir / "python", "-c", "import navlog"], work, user_env)

    assert "world-map" in run([bin_dir / "navlog", "--help"], work, user_env)

    run([bin_dir / "navlog", "world-map", "indoor_room", "-o", "m.yaml"], work, user_env)
    grid = yaml.safe_load((work / "m.yaml").read_text())
    assert grid["image"] == "m.pgm" and grid["resolution"] == 0.05 and (work / "m.pgm").stat().st_size > 1000

    out = run(
        [bin_dir / "navlog", "record", "--world", "indoor_room", "--scenario", "teleop", "-o", "t.mcap"], work, user_env
    )
    assert "scenario teleop" in out and "/scan" in out and (work / "t.mcap").stat().st_size > 100_000

    run(
        [bin_dir / "navlog", "replay", "t.mcap", "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", "rep"],
        work,
        user_env,
    )
    manifest = json.loads((work / "rep" / "manifest.json").read_text())
    files = {o["file"] for o in manifest["outputs"].values()}
    assert {"map.yaml", "map.pgm", "replay.mcap"} <= files and all((work / "rep" / f).is_file() for f in files)
    assert yaml.safe_load((work / "rep" / "map.yaml").read_text())["image"] == "map.pgm"

    out = run([bin_dir / "navlog", "view", "t.mcap", "--save", "x.rrd"], work, user_env)
    assert "x.rrd:" in out and (work / "x.rrd").stat().st_size > 10_000

    assert sorted(p.name for p in work.iterdir()) == ["m.pgm", "m.yaml", "rep", "t.mcap", "x.rrd"]


def test_installed_navlog_reads_a_users_config_folder(venv: Path, tmp_path: Path, user_env: dict[str, str]) -> None:
    navlog = venv / "bin" / "navlog"
    mine = tmp_path / "my-config"
    (mine / "worlds").mkdir(parents=True)
    box = "name: {}\nobjects:\n  - {{name: box_1, shape: box, size: [0.5, 0.5, 0.5], pose: [0.0, 0.0, 0.0]}}\n"
    (mine / "worlds" / "my_room.yaml").write_text(box.format("my_room"))
    work = tmp_path / "work"
    work.mkdir()
    env = {**user_env, "NAVLOG_CONFIG_PATH": str(mine)}

    run([navlog, "world-map", "my_room", "--margin", "0", "-o", "mine.yaml"], work, env)
    run([navlog, "world-map", "indoor_room", "--margin", "0", "-o", "builtin.yaml"], work, env)
    (mine / "worlds" / "indoor_room.yaml").write_text(box.format("indoor_room"))
    run([navlog, "world-map", "indoor_room", "--margin", "0", "-o", "replaced.yaml"], work, env)
    assert (work / "replaced.pgm").read_bytes() == (work / "mine.pgm").read_bytes()
    assert (work / "replaced.pgm").read_bytes() != (work / "builtin.pgm").read_bytes()

    res = subprocess.run(
        [navlog, "world-map", "no_room", "-o", "x.yaml"], cwd=work, env=env, capture_output=True, text=True
    )
    assert res.returncode == 2
    builtin = Path(
        run([venv / "bin" / "python", "-c", "import navlog.config; print(navlog.config.__file__)"], work, env).strip()
    )
    assert str(mine / "worlds") in res.stderr and str(builtin.parent / "worlds") in res.stderr, res.stderr
    assert "my_room" in res.stderr and "walled_room" in res.stderr
