"""What a built replay pipeline is: nodes, the topics they need and produce, and what it tells after its run.

A pipeline (``navlog.replay.pipelines``: a registered ``PipelineSpec``) builds a ``Pipeline`` for one
run. The replay runner (``navlog.replay.session``) opens the log, checks ``inputs``, streams exactly
those topics through the executor into ``nodes``, records ``outputs`` to ``OUT/replay.mcap``, then
calls ``write_artifacts`` and writes a manifest with every hash and count. The recorder runs the same
nodes live.

A pipeline with files to write, inputs to count or a result to report subclasses ``Pipeline`` and
overrides the methods below; their defaults say "nothing".
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from navlog.replay.runtime.executor import Node


class Pipeline:
    """The nodes of one run and their topics.

    - ``inputs``: topics that must be in the log; ``optional_inputs``: read when present;
    - ``outputs``: topics recorded into replay.mcap (never also read: a topic the pipeline regenerates
      is not streamed from the log, or the nodes would see each message twice);
    - ``published_outputs``: topics read from the log that the nodes publish on too (the SLAM's map -> odom
      on /tf): only the nodes' messages on them are recorded, not the log's own again;
    - ``info``: facts the pipeline decided from the log (e.g. the pose source it chose), for the manifest;
    - ``commands``: for a pipeline that filters velocity commands, (the topic it takes them on, the
      topic it gives them on): run live, the scenario publishes on the first and the robot drives on
      the second.
    """

    def __init__(
        self,
        name: str,
        nodes: Sequence[Node],
        inputs: Sequence[str],
        optional_inputs: Sequence[str] = (),
        outputs: Sequence[str] = (),
        *,
        published_outputs: Sequence[str] = (),
        info: dict[str, str] | None = None,
        commands: tuple[str, str] | None = None,
    ) -> None:
        self.name = name
        self.nodes = list(nodes)
        self.inputs = list(inputs)
        self.optional_inputs = list(optional_inputs)
        self.outputs = list(outputs)
        self.published_outputs = list(published_outputs)
        self.info = info if info is not None else {}
        self.commands = commands
        both = sorted(set(self.inputs + self.optional_inputs) & set(self.outputs))
        if both:
            raise ValueError(f"pipeline '{self.name}' both reads and publishes {', '.join(both)}")

    def write_artifacts(self, out: Path) -> dict[str, Path]:
        """After the run: write the pipeline's files into ``out``; {artifact name: path written}."""
        return {}

    def skipped(self) -> dict[str, int]:
        """Counts of skipped or invalid inputs, by reason, as the nodes counted them."""
        return {}

    def nothing_produced(self) -> str | None:
        """After the run: why nothing came of the main input (no map, no plan), or None when it produced its result."""
        return None

    def done(self) -> bool:
        """For a pipeline that drives the robot (navigation): True once its task has ended, and a live
        recording may stop (after the scenario's hold time)."""
        return False

    def report(self) -> dict[str, Any] | None:
        """What the pipeline did, for a summary (navigation: goal results), or None."""
        return None
