"""Producing logs: worlds, robots, sensors, the simulator node, scenarios and the recording run."""
