"""What a replay pipeline is: nodes, the topics they need, the topics they produce, the files they write.

A pipeline module in ``replay/pipelines/<name>.py`` defines a ``Params`` dataclass (its YAML in
``config/pipelines/<name>.yaml``) and ``build(params, log_topics) -> Pipeline``. The replay runner
(``navlog.replay.session``) opens the log, checks ``inputs``, streams exactly those topics through the
executor into ``nodes``, records ``outputs`` to ``OUT/replay.mcap``, then calls ``write_artifacts``
and writes a manifest with every hash and count.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from navlog.replay.runtime.executor import Node


@dataclass
class Pipeline:
    name: str
    nodes: list[Node]
    inputs: list[str]  # topics that must be in the log
    optional_inputs: list[str] = field(default_factory=list)  # read when present
    outputs: list[str] = field(default_factory=list)  # topics recorded into replay.mcap
    # called after the run with the output folder; returns {artifact name: path written}
    write_artifacts: Callable[[Path], dict[str, Path]] = lambda out: {}
    # counts of skipped or invalid inputs, by reason, filled in by the nodes
    skipped: Callable[[], dict[str, int]] = dict
    # facts the pipeline decided from the log (e.g. the pose source it chose), for the manifest
    info: dict[str, str] = field(default_factory=dict)
    # after the run: why nothing came of the main input (no map, no plan), or None when it produced its result
    nothing_produced: Callable[[], str | None] = lambda: None
    # a pipeline that filters velocity commands: (the topic it takes them on, the topic it gives them on);
    # run live, the scenario publishes its commands on the first and the robot drives on the second
    commands: tuple[str, str] | None = None
    # a pipeline that drives the robot itself (navigation): True once its task has ended, and a live
    # recording may stop (after the scenario's hold time)
    done: Callable[[], bool] | None = None
    # what the pipeline did, for a summary (navigation: goal results), or None
    report: Callable[[], dict] | None = None

    def __post_init__(self) -> None:
        # a topic the pipeline regenerates must not also be streamed from the log: the replay would hold
        # both copies and the nodes would see each message twice
        both = sorted(set(self.inputs + self.optional_inputs) & set(self.outputs))
        if both:
            raise ValueError(f"pipeline '{self.name}' both reads and publishes {', '.join(both)}")
