"""Running nodes over message streams: log readers and writers, the executor, TF, nodes, pipelines.

This package imports neither ``recorder`` nor ``analysis``; both of those build on it.
"""

__version__ = "0.1.0"
