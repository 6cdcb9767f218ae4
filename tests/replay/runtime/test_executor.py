"""The executor's order: time, then rank, then sequence; timers on sim time; streamed sources."""

from __future__ import annotations

from navlog.replay.runtime.executor import Envelope, Executor, Node


class Recorder(Node):
    def __init__(self, topics, log, name):
        super().__init__()
        self.topics, self.log, self.name = topics, log, name

    def setup(self):
        for t in self.topics:
            self.subscribe(t, lambda msg, ns, t=t: self.log.append((self.name, t, ns, msg)))


def test_source_messages_come_before_node_timers_at_equal_time():
    log: list = []
    ex = Executor()
    ex.add_source(
        [
            Envelope("/a", "x", 0, 1),
            Envelope("/a", "x", 100, 2),
            Envelope("/b", "x", 100, 3),
            Envelope("/a", "x", 250, 4),
        ]
    )

    class Timed(Node):
        def setup(self):
            self.subscribe("/a", lambda m, t: log.append(("a", t, m)))
            self.subscribe("/b", lambda m, t: log.append(("b", t, m)))
            self.create_timer(100, lambda t: log.append(("timer", t)), start_ns=0)

    ex.add_node(Timed())
    ex.run()
    assert log == [
        ("a", 0, 1),
        ("timer", 0),
        ("a", 100, 2),
        ("b", 100, 3),
        ("timer", 100),
        ("timer", 200),
        ("a", 250, 4),
    ]


def test_outputs_never_overtake_inputs_and_ties_keep_publication_order():
    log: list = []
    ex = Executor()

    class Echo(Node):
        def setup(self):
            self.subscribe("/in", lambda m, t: self.publish("/out", "x", m * 10))

    ex.add_source([Envelope("/in", "x", 5, 1), Envelope("/in", "x", 5, 2), Envelope("/in", "x", 7, 3)])
    ex.add_node(Echo())
    ex.add_node(Recorder(["/in", "/out"], log, "r"))
    ex.run()
    assert [(t, ns, m) for _, t, ns, m in log] == [
        ("/in", 5, 1),
        ("/in", 5, 2),
        ("/out", 5, 10),
        ("/out", 5, 20),
        ("/in", 7, 3),
        ("/out", 7, 30),
    ]


def test_source_is_streamed_not_loaded():
    pulled = []

    def gen():
        for i in range(1000):
            pulled.append(i)
            yield Envelope("/a", "x", i, i)

    ex = Executor()
    seen = []
    ex.add_source(gen())

    class Watch(Node):
        def setup(self):
            self.subscribe("/a", lambda m, t: seen.append(len(pulled) - m))

    ex.add_node(Watch())
    ex.run()
    assert len(seen) == 1000 and max(seen) <= 1  # at most one message read ahead


def test_live_run_until_and_finish():
    ex = Executor()
    fired = []

    class Tick(Node):
        def setup(self):
            self.create_timer(10, lambda t: fired.append(t), start_ns=0)

        def finish(self):
            self.publish("/done", "x", len(fired))

    got = []
    ex.add_node(Tick())
    ex.add_node(Recorder(["/done"], got, "r"))
    ex.run(until_ns=35)
    assert fired == [0, 10, 20, 30] and ex.now == 30
    ex.finish()
    assert got == [("r", "/done", 30, 4)]


def test_two_sources_merge_by_time_then_source_order():
    ex = Executor()
    log: list = []
    ex.add_source([Envelope("/a", "x", 1, "a1"), Envelope("/a", "x", 3, "a3")])
    ex.add_source([Envelope("/b", "x", 1, "b1"), Envelope("/b", "x", 2, "b2")])
    ex.add_node(Recorder(["/a", "/b"], log, "r"))
    ex.run()
    assert [m for *_, m in log] == ["a1", "b1", "b2", "a3"]


def test_subscriptions_declare_the_types_they_read():
    from navlog.replay.runtime.executor import Executor, Node

    class Reader(Node):
        def setup(self) -> None:
            self.subscribe("/scan", lambda m, t: None, ("sensor_msgs/msg/LaserScan",))
            self.subscribe("/tf", lambda m, t: None)  # no declaration: any type
            self.subscribe("/cloud", lambda m, t: None, ("sensor_msgs/msg/PointCloud2",))

    class Other(Node):
        def setup(self) -> None:
            self.subscribe("/cloud", lambda m, t: None, ("sensor_msgs/msg/LaserScan",))

    ex = Executor()
    ex.add_node(Reader())
    ex.add_node(Other())
    assert ex.subscribed_types() == {
        "/cloud": ("sensor_msgs/msg/LaserScan", "sensor_msgs/msg/PointCloud2"),
        "/scan": ("sensor_msgs/msg/LaserScan",),
    }


def test_a_topic_is_read_light_only_when_every_subscriber_takes_the_light_form():
    from navlog.replay.runtime.executor import Executor, Node

    class Buffer(Node):
        def setup(self) -> None:
            self.subscribe("/tf", lambda m, t: None, light=True)
            self.subscribe("/tf_static", lambda m, t: None, light=True)

    class Objects(Node):
        def setup(self) -> None:
            self.subscribe("/tf_static", lambda m, t: None)  # reads the message objects

    ex = Executor()
    ex.add_node(Buffer())
    assert ex.light_topics() == {"/tf", "/tf_static"}
    ex.add_node(Objects())
    assert ex.light_topics() == {"/tf"}
