"""The recorder starts no process, thread or pipe itself: its sensor worker runs in the execution layer
(``navlog.replay.workers.ring``), as the replay's workers do."""

from __future__ import annotations

from pathlib import Path

from tests.replay.test_package import concurrency_in

RECORDER = Path(__file__).resolve().parents[2] / "recorder"


def test_the_recorder_starts_no_process_thread_or_pipe() -> None:
    """The import-linter contract says the same of imports; this also sees ``os.fork`` and its kin."""
    files = sorted(RECORDER.rglob("*.py"))
    assert len(files) > 8  # every module of the recorder, scanned
    found = {str(f.relative_to(RECORDER)): hits for f in files if (hits := concurrency_in(f.read_text()))}
    assert found == {}
