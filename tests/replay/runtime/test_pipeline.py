"""The pipeline description: a topic is read from the log or regenerated, never both."""

from __future__ import annotations

import pytest

from navlog.replay.runtime.pipeline import Pipeline


def test_a_topic_both_read_and_published_is_refused() -> None:
    Pipeline("ok", [], inputs=["/scan"], optional_inputs=["/tf"], outputs=["/map"])
    with pytest.raises(ValueError, match="pipeline 'twice' both reads and publishes /footprint, /map"):
        Pipeline("twice", [], inputs=["/scan", "/map"], optional_inputs=["/footprint"], outputs=["/map", "/footprint"])
