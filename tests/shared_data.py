"""Where the external data lives: the real bags, the public robots' Nav2 files and the seed texts.

They are not in the repository. The folder is the one the environment variable ``NAVLOG_SHARED_DIR``
names, else ``shared`` beside the repository (``REPO/../shared``); it holds ``external-data/bags``,
``external-data/params`` and ``seeds``. The tests (``tests/conftest.py``), the fuzz campaign and the
benchmarks all take it from ``default_shared_dir``; nothing here checks that the folder exists.
"""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED_DIR_VARIABLE = "NAVLOG_SHARED_DIR"


def default_shared_dir() -> Path:
    """``$NAVLOG_SHARED_DIR`` when set and not empty, else ``REPO/../shared``; absolute, whatever the cwd."""
    named = os.environ.get(SHARED_DIR_VARIABLE)
    return Path(named).expanduser().resolve() if named else (REPO.parent / "shared").resolve()
