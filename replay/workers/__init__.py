"""The execution layer: every process, thread and pipe that a replay or a recording runs work in.

Algorithms (``navlog.replay.mapping``, ``navlog.replay.nav2``) are pure and synchronous; a node that
wants their work to run beside its own thread asks this package, which runs the same pure calls in a
child process or a thread and gives back the same bits in the same order:

- ``child``: a child Python answering requests over its pipes (frames of an opcode and raw bytes,
  errors and a dead child named, nothing left behind after a Ctrl-C), and how every child process
  here is started and ended;
- ``ring``: ``RingProcess``, a child Python answering requests in order with large results through a
  shared-memory ring, the caller never waiting for it while a result is due (the recorder's laser
  and LiDAR, ``navlog.recorder.range_sensors``);
- ``grid``: ``GridWorker``, the occupancy grid's scan updates in a child process;
- ``odometry``: ``OdometryFrames``, the 3D odometry's frames completed here or ahead in a child process
  (``OdometryWorker``, the child's side);
- ``background``: ``in_thread``, pure work (the 3D global map's batches) in a thread beside the caller;
  ``SerialThread``, calls given often (MPPI's next noise) run in order in one thread.

Every worker has the same shape: made to run offloaded (or, where it can, in this process: one CPU,
no child could start), its calls return at once where no answer is needed, the calls that need one
wait for it, answers come in the order asked, and ``close`` ends what it started. The worker decides
where the work runs; the algorithm decides what runs and in what order, so the outputs never depend
on it (tested per worker).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.workers.background import SerialThread, in_thread
    from navlog.replay.workers.child import ChildProcess
    from navlog.replay.workers.grid import GridWorker
    from navlog.replay.workers.odometry import OdometryFrames, OdometryWorker
    from navlog.replay.workers.ring import RingProcess

__all__ = ["ChildProcess", "GridWorker", "OdometryFrames", "OdometryWorker", "RingProcess", "SerialThread", "in_thread"]

_MODULES = {
    "ChildProcess": "child",
    "GridWorker": "grid",
    "OdometryFrames": "odometry",
    "OdometryWorker": "odometry",
    "RingProcess": "ring",
    "SerialThread": "background",
    "in_thread": "background",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
