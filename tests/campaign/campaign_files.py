"""A small campaign file the campaign and CI tests start from: one generated corridor, the Go2, one variant."""

from __future__ import annotations

from pathlib import Path

BASE = """name: t
worlds:
  - {generate: corridor, count: 1, params: {doors: 0, length: 6.0}}
robots: [go2]
variants:
  - {name: a, nav2_params: nav_go2}
"""


def write(tmp_path: Path, text: str) -> Path:
    """``text`` as ``tmp_path/c.yaml``."""
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return path
