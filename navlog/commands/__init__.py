"""The ``navlog`` commands, one module each (``navlog world-map`` is ``world_map.py``).

Each module has ``register(subparsers)``, which adds the command's parser, and ``run(args)``, which
calls the library function a Python user would call and prints its result. A module imports the
library only inside ``run``, so that building the parser (and ``--help``) loads nothing heavy.
"""

__all__: list[str] = []
