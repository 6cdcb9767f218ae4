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


def test_a_sink_tells_what_nodes_published_from_what_a_source_delivered():
    from navlog.replay.runtime.executor import Published

    written: list = []
    ex = Executor()

    class Echo(Node):
        def setup(self):
            self.subscribe("/in", self._on)

        def _on(self, m, t):
            self.publish("/tf", "x", m * 10)
            slot = self.defer()  # a deferred output is the node's too
            slot.publish("/tf", "x", m * 100)
            slot.close()

    ex.add_source([Envelope("/in", "x", 5, 1), Envelope("/tf", "x", 7, 2)])
    ex.add_node(Echo())
    ex.add_sink(
        type("Sink", (), {"write": lambda self, e: written.append((e.topic, e.msg, isinstance(e, Published)))})()
    )
    ex.run()
    assert written == [("/in", 1, False), ("/tf", 10, True), ("/tf", 100, True), ("/tf", 2, False)]


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


def _runs_of_sources(step: bool, chunk: int | None, stop_at: int | None = None) -> tuple[list, list, int]:
    """Two sources (one with a message older than the time reached), a 10 ns timer, a node echoing /a at
    the same instant and a sink: what the nodes and the sink saw, in order, and the messages left."""
    ex = Executor()
    a = [Envelope("/a", "x", t, f"a{t}") for t in (0, 5, 5, 10, 12, 12, 20, 21, 30, 40, 41, 42)]
    b = [Envelope("/b", "x", t, f"b{t}") for t in (3, 5, 10, 11, 9, 30, 50)]  # b9 after b11: out of order
    ex.add_source(a)
    ex.add_source(b)
    seen: list = []
    written: list = []

    class Echo(Node):
        def setup(self):
            self.subscribe("/a", lambda m, t: self.publish("/echo", "x", m + "!"))
            self.subscribe("/b", self._on_b)
            self.create_timer(10, lambda t: seen.append(("timer", t)), start_ns=0)

        def _on_b(self, m, t):
            if t == stop_at:
                self.executor.stop()

    ex.add_node(Echo())
    ex.add_node(Recorder(["/a", "/b", "/echo"], seen, "r"))
    ex.add_sink(type("Sink", (), {"write": lambda self, env: written.append((env.topic, env.time_ns, env.msg))})())
    on_step = (lambda t: None) if step else None
    if chunk is None:
        ex.run(on_step=on_step)
    else:
        until = 0
        while ex.sources_pending and not ex._stopped:
            until += chunk
            ex.run(until_ns=until, on_step=on_step)
    return seen, written, ex.stats.out_of_order


def test_a_sources_messages_delivered_without_the_queue_keep_the_order():
    """A source's next message is delivered at once when it is the next event (no ``on_step``): the
    nodes and the sinks see exactly what the event queue gives (``on_step`` set), in whole runs, in
    runs up to a time, and when a callback stops the run."""
    for chunk in (None, 7, 10):
        queued = _runs_of_sources(True, chunk)
        assert _runs_of_sources(False, chunk) == queued
        names = [m for *_, m in queued[0]]
        assert queued[2] == 1 and names.index("b9") == names.index("b11") + 1  # late, delivered when it came
    stopped = _runs_of_sources(False, None, stop_at=10)
    assert stopped == _runs_of_sources(True, None, stop_at=10)
    assert stopped[0][-1] == ("r", "/b", 10, "b10")  # nothing after the message whose callback stopped it


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


class _Writes:
    """A sink: every message written, as (topic, time, message)."""

    def __init__(self) -> None:
        self.items: list = []

    def write(self, env):
        self.items.append((env.topic, env.time_ns, env.msg))


def _sink_order(deferred: bool, close_from_thread: bool = False) -> tuple[list, Executor]:
    """/in at 5, 5, 7, 9; a node (rank 1) answers each with two /out messages, at once or deferred and
    filled one input later (the last at finish); a node of rank 2 answers each with /later at the same time,
    and one of rank 1's timers ticks /tick every 2 ns."""
    import threading

    ex = Executor()
    ex.add_source([Envelope("/in", "x", t, k) for k, t in enumerate((5, 5, 7, 9))])

    class Answer(Node):
        def setup(self):
            self.open = []
            self.threads = []
            self.subscribe("/in", self.on_in)
            self.create_timer(2, lambda t: self.publish("/tick", "x", t), start_ns=4)

        def on_in(self, m, t):
            if not deferred:
                self.publish("/out", "x", (m, "a"))
                self.publish("/out", "x", (m, "b"))
                return
            self.fill_open()
            slot = self.defer()
            slot.publish("/out", "x", (m, "a"))
            slot.publish("/out", "x", (m, "b"))
            self.open.append(slot)

        def fill_open(self):
            for slot in self.open:
                if close_from_thread:
                    th = threading.Thread(target=slot.close)
                    th.start()
                    self.threads.append(th)
                else:
                    slot.close()
            self.open = []

        def finish(self):
            self.fill_open()
            for th in self.threads:
                th.join()

    class Later(Node):
        def setup(self):
            self.subscribe("/in", lambda m, t: self.publish("/later", "x", m))

    ex.add_node(Answer())
    ex.add_node(Later())
    sink = _Writes()
    ex.add_sink(sink)
    ex.run()
    ex.finish()
    return sink.items, ex


def test_deferred_outputs_reach_the_sinks_where_published_outputs_would():
    now, stats_now = _sink_order(deferred=False)
    later, stats_later = _sink_order(deferred=True)
    assert later == now
    assert stats_later.stats.published == stats_now.stats.published == {"/out": 8, "/later": 4, "/tick": 3}
    # the order itself: inputs first at equal time, then rank 1's outputs, then rank 2's
    assert now[:8] == [
        ("/tick", 4, 4),
        ("/in", 5, 0),
        ("/in", 5, 1),
        ("/out", 5, (0, "a")),
        ("/out", 5, (0, "b")),
        ("/out", 5, (1, "a")),
        ("/out", 5, (1, "b")),
        ("/later", 5, 0),
    ]
    assert _sink_order(deferred=True, close_from_thread=True)[0] == now


def test_an_open_deferred_holds_later_writes_until_it_closes():
    import threading

    import pytest

    from navlog.errors import NavlogError

    ex = Executor()
    ex.add_source([Envelope("/in", "x", t, t) for t in (1, 2, 3, 4)])
    slots = []

    class Slow(Node):
        def setup(self):
            self.subscribe("/in", lambda m, t: slots.append(self.defer()) if m in (1, 4) else None)

    ex.add_node(Slow())
    sink = _Writes()
    ex.add_sink(sink)
    ex.run(until_ns=3)
    assert sink.items == [("/in", 1, 1)]  # /in at 2 and 3 wait behind the open deferred
    slots[0].publish("/out", "x", "late")
    closing = threading.Thread(target=slots[0].close)  # closed on another thread: written at the next step
    closing.start()
    closing.join()
    assert sink.items == [("/in", 1, 1)]
    ex.run()
    assert sink.items == [("/in", 1, 1), ("/out", 1, "late"), ("/in", 2, 2), ("/in", 3, 3), ("/in", 4, 4)]
    slots[1].publish("/out", "x", "never")  # the node never closes it: finish says so
    with pytest.raises(NavlogError, match="1 message"):
        ex.finish()


def test_a_deferred_closed_on_the_executors_thread_passes_on_what_waited_at_once():
    ex = Executor()
    ex.add_source([Envelope("/in", "x", t, t) for t in (1, 2)])
    slots = []

    class Later(Node):
        def setup(self):
            self.subscribe("/in", self.on_in)

        def on_in(self, m, t):
            if slots:
                slots[0].publish("/out", "x", "filled")
                slots[0].close()
                assert sink.items == [
                    ("/in", 1, 1),
                    ("/out", 1, "filled"),
                    ("/in", 2, 2),
                ]  # before this callback returns
            else:
                slots.append(self.defer())

    ex.add_node(Later())
    sink = _Writes()
    ex.add_sink(sink)
    ex.run()
    assert sink.items == [("/in", 1, 1), ("/out", 1, "filled"), ("/in", 2, 2)]
    ex.finish()


def test_read_by_nodes_names_outputs_a_node_subscribes_to():
    ex = Executor()
    ex.add_node(Recorder(["/odom"], [], "r"))
    assert ex.read_by_nodes(["/map", "/odom"])
    assert not ex.read_by_nodes(["/map", "/cloud"])


def test_a_message_published_as_cdr_reaches_sinks_as_bytes_and_subscribers_as_the_message():
    from navlog.replay import messages

    data = messages.serialize(messages.twist(0.25, 0.0, -0.5), messages.TWIST)

    class Publisher(Node):
        def setup(self):
            self.create_timer(5, lambda t: self.publish_cdr(self.topic, messages.TWIST, data), start_ns=5)

    for read in (False, True):
        ex, sink, log, pub = Executor(), _Writes(), [], Publisher()
        pub.topic = "/cmd_vel"
        ex.add_sink(sink)
        ex.add_node(pub)
        if read:
            ex.add_node(Recorder(["/cmd_vel"], log, "r"))
        ex.run(until_ns=5)
        (topic, t, msg), *_ = sink.items
        if read:  # the message decoded once: the subscriber and the sinks see the same object
            assert log[0][3] is msg and (msg.linear.x, msg.angular.z) == (0.25, -0.5)
        else:
            assert msg is data and not log


def test_an_envelope_is_a_frozen_dataclass():
    import dataclasses

    import pytest

    env = Envelope("/a", "x", 5, "m")
    assert dataclasses.replace(env, time_ns=7) == Envelope("/a", "x", 7, "m")
    assert dataclasses.asdict(env) == {"topic": "/a", "typename": "x", "time_ns": 5, "msg": "m"}
    assert hash(env) == hash(Envelope(topic="/a", typename="x", time_ns=5, msg="m")) and env != Envelope(
        "/a", "x", 6, "m"
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        env.time_ns = 6  # type: ignore[misc]


def test_a_run_begun_later_starts_its_timers_there_and_its_sources_where_they_are():
    log: list = []
    ex = Executor(start_ns=0)

    class Timed(Node):
        def setup(self):
            self.subscribe("/a", lambda m, t: log.append(("a", t, m)))
            self.create_timer(100, lambda t: log.append(("timer", t)))

    ex.add_node(Timed())
    ex.add_source([Envelope("/a", "x", 1_000, 1), Envelope("/a", "x", 1_150, 2)])
    assert ex.next_source_ns() == 1_000
    ex.begin_at(1_000)
    ex.begin_at(500)  # never back
    ex.run()
    assert ex.now == 1_150
    assert log == [("a", 1_000, 1), ("timer", 1_000), ("timer", 1_100), ("a", 1_150, 2)]
