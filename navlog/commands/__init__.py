"""The ``navlog`` commands, one module each (``navlog world-map`` is ``world_map.py``).

Each module has ``register(subparsers)``, which adds the command's parser, and ``run(args)``, which
calls the library function a Python user would call and prints its result. A module imports the
library only inside ``run``, so that building the parser (and ``--help``) loads nothing heavy.
"""

__all__ = ["skipped_note"]


def skipped_note(skipped: dict[str, int]) -> str:
    """'; skipped N: reason xK; ...' for a command's one-line summary, or '' when nothing was skipped."""
    total = sum(skipped.values())
    if not total:
        return ""
    return f"; skipped {total}: " + "; ".join(f"{k} x{v}" for k, v in sorted(skipped.items()))
