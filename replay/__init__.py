"""Running nodes over message streams: log readers and writers, the executor, TF, nodes, pipelines.

This package imports neither ``navlog.recorder`` nor ``navlog.analysis``; both of those build on it.
"""
