"""Replay pipelines: one module per pipeline, each with ``Params`` and ``build(params, log_topics)``."""
