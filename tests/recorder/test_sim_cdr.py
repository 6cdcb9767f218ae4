"""The simulator's direct CDR: a log is the same bytes whether its messages were built as objects or not."""

from __future__ import annotations

import hashlib

import pytest

from navlog.recorder.robot import load_robot
from navlog.recorder.sim import SimNode, SimOptions
from navlog.recorder.world import load_world
from navlog.replay import messages
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Executor, Node

HIGH_RATE = ("/clock", "/imu/data", "/odom", "/odom/ground_truth", "/tf")


class _Listen(Node):
    """Subscribes to the high-rate topics, so the simulator builds their message objects."""

    def __init__(self) -> None:
        super().__init__()
        self.got: dict[str, list] = {t: [] for t in HIGH_RATE}

    def setup(self) -> None:
        for topic in HIGH_RATE:
            self.subscribe(topic, lambda msg, ns, topic=topic: self.got[topic].append(msg))


class _Kinds:
    """A sink noting what the simulator published on each topic: objects or bytes."""

    def __init__(self) -> None:
        self.kinds: dict[str, set[str]] = {}

    def write(self, env) -> None:
        self.kinds.setdefault(env.topic, set()).add("bytes" if isinstance(env.msg, bytes) else "object")


def _record(path, robot: str, listen: bool) -> tuple[_Kinds, _Listen | None]:
    ex = Executor()
    ex.add_node(SimNode(load_world("indoor_room"), load_robot(robot), SimOptions(seed=5, start=(0.5, -0.5, 0.3))))
    listener = _Listen() if listen else None
    if listener is not None:
        ex.add_node(listener)

    class Drive(Node):
        def setup(self) -> None:
            self.create_timer(
                50_000_000, lambda t: self.publish("/cmd_vel", messages.TWIST, messages.twist(0.2, 0.0, 0.4)), 0
            )

    ex.add_node(Drive())
    kinds = _Kinds()
    ex.add_sink(kinds)
    with McapLogWriter(path, background=True) as writer:
        ex.add_sink(writer)
        ex.run(until_ns=400_000_000)
    return kinds, listener


@pytest.mark.parametrize("robot", ["go2", "simple_robot"])  # with and without a base_footprint frame
def test_direct_cdr_writes_the_bytes_of_the_message_objects(tmp_path, robot):
    raw, _ = _record(tmp_path / "raw.mcap", robot, listen=False)
    obj, listener = _record(tmp_path / "obj.mcap", robot, listen=True)
    raw_kinds, obj_kinds = raw.kinds, obj.kinds
    imu_topic = load_robot(robot).imu.topic
    assert raw_kinds[imu_topic] == raw_kinds["/tf"] == raw_kinds["/clock"] == {"bytes"}
    assert obj_kinds[imu_topic] == obj_kinds["/tf"] == obj_kinds["/clock"] == {"object"}
    assert listener is not None and len(listener.got["/clock"]) == 41 and len(listener.got["/tf"]) == 21
    assert listener.got["/tf"][-1].transforms[0].header.frame_id == "map"
    digest = [hashlib.sha256((tmp_path / name).read_bytes()).hexdigest() for name in ("raw.mcap", "obj.mcap")]
    assert digest[0] == digest[1]
