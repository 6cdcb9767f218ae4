"""navlog's built-in YAML: worlds, models, robots, scenarios, goals and pipelines (package data).

Read through ``navlog.replay.config`` (``config_dirs``, ``named_config``), which searches the
folders of ``NAVLOG_CONFIG_PATH`` first and these files last.
"""
