"""The documentation: the site builds strictly (no broken link, no missing page), its generated
reference pages hold every command and key, the README is short, and every example marked runnable
in the README and the docs runs.

A runnable example is a fenced ``bash`` block right after a ``<!-- runnable -->`` line. The blocks of
one file run in order in one empty folder (a later block may read what an earlier one wrote), with the
checkout's ``navlog`` first on the PATH; each command must exit 0.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
RUNNABLE = re.compile(r"<!-- runnable -->\s*\n```bash\n(.*?)```", re.S)


def runnable_blocks(text: str) -> list[str]:
    return [m.group(1) for m in RUNNABLE.finditer(text)]


def run_blocks(blocks: list[str], folder: Path) -> None:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}
    for block in blocks:
        for line in block.strip().splitlines():
            command = line.split("#")[0].strip()
            if not command:
                continue
            command = command.replace("config/", f"{REPO}/config/")
            res = subprocess.run(
                ["bash", "-c", command], cwd=folder, env=env, capture_output=True, text=True, timeout=600
            )
            assert res.returncode == 0, f"{command}\n{res.stdout[-2000:]}{res.stderr[-2000:]}"


def test_runnable_blocks_are_found():
    text = "x\n<!-- runnable -->\n```bash\nnavlog info a.mcap\n```\n```bash\nnot this\n```\n"
    assert runnable_blocks(text) == ["navlog info a.mcap\n"]


def test_the_readme_is_short_and_links_into_the_docs():
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    for link in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (REPO / link).is_file(), link


@pytest.mark.slow
def test_the_site_builds_strictly_with_every_command_and_key(tmp_path):
    site = tmp_path / "site"
    res = subprocess.run(
        [str(BIN / "mkdocs"), "build", "--strict", "-d", str(site)],
        cwd=REPO,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    cli = (site / "reference" / "cli" / "index.html").read_text()
    from navlog.cli import COMMANDS

    assert all(f"navlog {name}" in cli for name in COMMANDS)
    config = (site / "reference" / "config" / "index.html").read_text()
    for key in ("occupancy.grid.no_return_ray_length", "objects[].pose", "publish_period"):
        assert key in config
    api = (site / "reference" / "api" / "index.html").read_text()
    assert "OdometryFrames" in api and "run_replay" in api


@pytest.mark.slow
def test_the_readme_examples_run(tmp_path):
    blocks = runnable_blocks((REPO / "README.md").read_text())
    assert len(blocks) >= 7
    run_blocks(blocks, tmp_path)
    assert (tmp_path / "replay" / "map.yaml").is_file() and (tmp_path / "mapping_bag" / "metadata.yaml").is_file()


RUNNABLE_PAGES = sorted(
    p.relative_to(REPO / "docs").as_posix()
    for p in (REPO / "docs").rglob("*.md")
    if "<!-- runnable -->" in p.read_text()
)


@pytest.mark.slow
@pytest.mark.parametrize("page", RUNNABLE_PAGES)
def test_the_docs_examples_run(page, tmp_path):
    blocks = runnable_blocks((REPO / "docs" / page).read_text())
    assert blocks, f"{page}: a runnable marker without a bash block after it"
    run_blocks(blocks, tmp_path)
