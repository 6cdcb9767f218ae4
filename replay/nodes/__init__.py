"""Nodes that run on the executor, live or in replay: mappers, costmaps, planners, filters."""
