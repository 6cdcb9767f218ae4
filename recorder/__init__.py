"""Producing logs: worlds, robots, sensors, the simulator node, scenarios and the recording run.

Its public API, imported on first use so that importing the package stays cheap:

- ``prepare(world, robot, scenario, seed, noise)`` loads and checks a ``RecordSetup``;
  ``navlog.recorder.record.record(setup, out, ...)`` simulates it into an MCAP log and returns a
  ``RecordResult`` (``format_summary`` prints it; ``expected_duration`` estimates a run's length);
  ``record(..., pipeline=...)`` runs a replay pipeline live (the safety filters between the
  scenario's commands and the robot).
  The function is not re-exported here: its name is that of its module, ``navlog.recorder.record``;
- ``load_world`` / ``load_robot`` / ``load_scenario`` read the YAML descriptions (``World``,
  ``RobotSpec``, ``ScenarioSpec``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.recorder.record import (
        RecordResult,
        RecordSetup,
        expected_duration,
        format_summary,
        prepare,
    )
    from navlog.recorder.robot import RobotSpec, load_robot
    from navlog.recorder.scenarios import ScenarioSpec, load_scenario
    from navlog.recorder.world import World, load_world

__all__ = [
    "RecordResult",
    "RecordSetup",
    "RobotSpec",
    "ScenarioSpec",
    "World",
    "expected_duration",
    "format_summary",
    "load_robot",
    "load_scenario",
    "load_world",
    "prepare",
]

# the module, below this package, that defines each public name
_MODULES = {
    "RecordResult": "record",
    "RecordSetup": "record",
    "expected_duration": "record",
    "format_summary": "record",
    "prepare": "record",
    "RobotSpec": "robot",
    "load_robot": "robot",
    "ScenarioSpec": "scenarios",
    "load_scenario": "scenarios",
    "World": "world",
    "load_world": "world",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
