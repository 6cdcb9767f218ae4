"""The executor: one deterministic order of messages and timers, the same live and in replay.

Nodes subscribe to topics, publish messages and own timers on sim time (integer nanoseconds).
Every delivery and every timer firing is an event with the key (time, rank, sequence):

- time: the message's log time (its publish time on the sim clock) or the timer's due time;
- rank: the rank of what produced it: sources (a log reader, the simulator) have rank 0, other
  nodes rank 1, 2, ... in the order they were added;
- sequence: a counter that grows with every event, so ties keep the order of publication.

A node publishes at the current time only, so outputs never overtake inputs. Replaying a log
through the same nodes delivers their inputs in the same order as the live run did, which is why
their outputs come out bit for bit the same.

A node may also give outputs that only sinks read later (computed by a worker process or thread):
``Node.defer()`` takes their place in the order now, as a ``Deferred``, and the sinks receive them
there once the node fills and closes it; what comes after it waits for it. The sinks see the same
messages in the same order whenever the outputs came, as if the node had published them at once.
"""

from __future__ import annotations

import heapq
import threading
from collections import Counter, deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

from navlog.errors import NavlogError
from navlog.replay import messages

Callback = Callable[[Any, int], None]  # (message, time_ns)


@dataclass(frozen=True)
class Envelope:
    """A message in flight: topic, type name, time (ns) and the message (or its raw CDR bytes)."""

    topic: str
    typename: str
    time_ns: int
    msg: Any

    def __init__(self, topic: str, typename: str, time_ns: int, msg: Any) -> None:
        # the fields written straight into the instance (kept by @dataclass): a third cheaper than the
        # frozen class's one object.__setattr__ per field, on every message's path; frozen as before
        d = self.__dict__
        d["topic"], d["typename"], d["time_ns"], d["msg"] = topic, typename, time_ns, msg


class Published(Envelope):
    """A message a node published (``Node.publish``, ``Node.defer``), not one read from a log: a sink that records
    a topic carrying both (the nodes' map -> odom on a log's /tf) tells them apart by this class."""

    __slots__ = ()


class Deferred:
    """A node's outputs of one instant, filled later (on any thread) and written to the sinks in the
    place ``Node.defer`` took for them (see the module docstring)."""

    __slots__ = ("_release", "_thread", "closed", "outputs", "time_ns")

    def __init__(self, time_ns: int, release: Callable[[], None] | None = None) -> None:
        self.time_ns = time_ns
        self.outputs: list[tuple[str, str, Any]] = []  # (topic, type name, message or CDR bytes), in order
        self.closed = False
        self._release = release  # the executor's: what waited behind this goes to the sinks
        self._thread = threading.get_ident()

    def publish(self, topic: str, typename: str, msg: Any) -> None:
        self.outputs.append((topic, typename, msg))

    def close(self) -> None:
        """Every output is in: the sinks may have them (at once when closed on the executor's thread,
        else from the executor's next step)."""
        self.closed = True
        if self._release is not None and threading.get_ident() == self._thread:
            self._release()


class Sink(Protocol):
    """Something that sees every published message (the MCAP recorder is one)."""

    def write(self, env: Envelope) -> None: ...


class Node:
    """Base class of everything that runs on the executor: subclass and override ``setup``."""

    name = "node"

    def __init__(self) -> None:
        self._executor: Executor | None = None
        self.rank = 0
        self.skipped: Counter[str] = Counter()  # inputs the node could not use, by reason

    def skipped_counts(self) -> dict[str, int]:
        """The inputs this node could not use, by reason (a node adds the counts its algorithms keep)."""
        return dict(self.skipped)

    # -- called by the executor
    def attach(self, executor: Executor, rank: int) -> None:
        self._executor = executor
        self.rank = rank
        self.setup()

    def setup(self) -> None:
        """Declare subscriptions, publishers and timers here."""

    def finish(self) -> None:
        """Called once after the last event: flush state, publish final outputs."""

    # -- used by node code
    @property
    def executor(self) -> Executor:
        if self._executor is None:
            raise RuntimeError(f"node {self.name} is not attached to an executor")
        return self._executor

    def now(self) -> int:
        return self.executor.now

    def subscribe(self, topic: str, callback: Callback, types: tuple[str, ...] = (), *, light: bool = False) -> None:
        """Call ``callback(msg, time_ns)`` for every message on ``topic``; ``types`` names the message types
        the callback reads (checked against a log's topics before a replay starts). ``light``: the callback
        also takes a type's light form (``messages.TFTransforms``), which a replay then reads the topic as
        when every subscriber of it takes it."""
        self.executor.subscribe(topic, callback, types, light=light)

    def publish(self, topic: str, typename: str, msg: Any) -> None:
        self.executor.publish(Published(topic, typename, self.executor.now, msg), self.rank)

    def publish_cdr(self, topic: str, typename: str, data: bytes) -> None:
        """Publish a message given as its CDR bytes: the bytes when only sinks see ``topic``, the message
        decoded from them when a node subscribes to it."""
        self.publish(
            topic, typename, messages.deserialize(data, typename) if self.executor.has_subscribers(topic) else data
        )

    def create_timer(self, period_ns: int, callback: Callable[[int], None], start_ns: int | None = None) -> None:
        self.executor.add_timer(period_ns, callback, self.rank, start_ns)

    def defer(self) -> Deferred:
        """The place, now, of outputs the node fills in later (only sinks may read them: see
        ``Executor.read_by_nodes``)."""
        return self.executor.defer(self.rank)


@dataclass
class _Timer:
    period_ns: int
    callback: Callable[[int], None]
    rank: int


@dataclass
class Stats:
    """What the executor did: messages delivered per topic, timer firings, skipped items."""

    delivered: dict[str, int] = field(default_factory=dict)
    published: dict[str, int] = field(default_factory=dict)
    timer_fires: int = 0
    out_of_order: int = 0  # source messages older than the current time, delivered at it


class Executor:
    """Runs nodes over sources in the (time, rank, sequence) order; see the module docstring."""

    def __init__(self, start_ns: int = 0) -> None:
        """``start_ns``: the time before the first event (a replay starts at the log's first message),
        where timers created without a start time begin."""
        self.now = int(start_ns)
        self._seq = 0
        self._queue: list[tuple[int, int, int, str, Any]] = []
        self._subs: dict[str, list[Callback]] = {}
        self._sub_types: dict[str, set[str]] = {}
        self._light: dict[str, bool] = {}  # topic -> every subscriber takes the light form
        self._timers: list[_Timer] = []
        self._nodes: list[Node] = []
        self._sinks: list[Sink] = []
        self._sources: list[Iterator[Envelope]] = []
        self.stats = Stats()
        self._stopped = False
        self._pending_sources = 0  # source events in the queue (at most one per source)
        self._held: deque[Envelope | Deferred] = deque()  # sink writes behind a Deferred still open

    # ------------------------------------------------------------ wiring
    def add_node(self, node: Node, *, source: bool = False) -> Node:
        """Attach a node; a source node (a simulator) publishes at rank 0, others after it."""
        rank = 0 if source else len([n for n in self._nodes if n.rank > 0]) + 1
        self._nodes.append(node)
        node.attach(self, rank)
        return node

    def add_source(self, messages: Iterable[Envelope]) -> None:
        """A stream of recorded messages (log time order), published at rank 0 as it is consumed."""
        it = iter(messages)
        self._sources.append(it)
        self._pull(len(self._sources) - 1)

    def add_sink(self, sink: Sink) -> None:
        self._sinks.append(sink)

    def next_source_ns(self) -> int | None:
        """The time of the next recorded message waiting to be delivered (None when no source has one)."""
        times = [event[0] for event in self._queue if event[3] == "source"]
        return min(times) if times else None

    def begin_at(self, t_ns: int) -> None:
        """Before the first run: start at ``t_ns`` instead (when later than ``now``); timers due before it
        begin there, in their order."""
        if t_ns <= self.now:
            return
        self.now = int(t_ns)
        self._queue = [(max(e[0], self.now), *e[1:]) if e[3] == "timer" else e for e in self._queue]
        heapq.heapify(self._queue)

    def subscribe(self, topic: str, callback: Callback, types: tuple[str, ...] = (), *, light: bool = False) -> None:
        self._subs.setdefault(topic, []).append(callback)
        self._light[topic] = self._light.get(topic, True) and light
        if types:
            self._sub_types.setdefault(topic, set()).update(types)

    def light_topics(self) -> set[str]:
        """The topics every subscriber of which takes the light form of its messages."""
        return {topic for topic, light in self._light.items() if light}

    def read_by_nodes(self, topics: Iterable[str]) -> bool:
        """True when a node subscribes to one of ``topics`` (outputs that cannot be deferred)."""
        return any(t in self._subs for t in topics)

    def has_subscribers(self, topic: str) -> bool:
        """True when a node subscribes to ``topic`` (else only sinks see it: raw CDR bytes will do)."""
        return topic in self._subs

    def subscribed_types(self) -> dict[str, tuple[str, ...]]:
        """Topic -> the message types its subscribers read, for the topics whose subscribers declared them."""
        return {topic: tuple(sorted(types)) for topic, types in sorted(self._sub_types.items())}

    def add_timer(self, period_ns: int, callback: Callable[[int], None], rank: int, start_ns: int | None) -> None:
        if period_ns <= 0:
            raise NavlogError(f"timer period must be positive, got {period_ns} ns")
        idx = len(self._timers)
        self._timers.append(_Timer(int(period_ns), callback, rank))
        first = self.now if start_ns is None else int(start_ns)
        self._push(first, rank, "timer", idx)

    # ------------------------------------------------------------ events
    def _push(self, t: int, rank: int, kind: str, payload: Any) -> None:
        self._seq += 1
        heapq.heappush(self._queue, (t, rank, self._seq, kind, payload))

    def _pull(self, index: int) -> None:
        event = self._source_event(index)
        if event is not None:
            heapq.heappush(self._queue, event)

    def _source_event(self, index: int) -> tuple | None:
        """The event of a source's next message (None when it has run dry), not queued yet."""
        env = next(self._sources[index], None)
        if env is None:
            return None
        self._pending_sources += 1
        if env.time_ns < self.now:
            self.stats.out_of_order += 1
        self._seq += 1
        return (max(env.time_ns, self.now), 0, self._seq, "source", (index, env))

    def publish(self, env: Envelope, rank: int) -> None:
        self.stats.published[env.topic] = self.stats.published.get(env.topic, 0) + 1
        self._push(env.time_ns, rank, "msg", env)

    def defer(self, rank: int) -> Deferred:
        """A ``Deferred`` at the current time, in ``rank``'s place among the events (``Node.defer``)."""
        slot = Deferred(self.now, self._release)
        self._push(self.now, rank, "deferred", slot)
        return slot

    def _write(self, item: Envelope | Deferred) -> None:
        """To the sinks, in order: behind an open ``Deferred``, held until it closes."""
        if self._held or (isinstance(item, Deferred) and not item.closed):
            self._held.append(item)
            self._release()
        else:
            self._emit(item)

    def _emit(self, item: Envelope | Deferred) -> None:
        """A message, or a closed ``Deferred``'s messages at its time, to every sink."""
        if isinstance(item, Deferred):
            published = self.stats.published
            envs: list[Envelope] = [
                Published(topic, typename, item.time_ns, msg) for topic, typename, msg in item.outputs
            ]
            for env in envs:
                published[env.topic] = published.get(env.topic, 0) + 1
        else:
            envs = [item]
        for env in envs:
            for sink in self._sinks:
                sink.write(env)

    def _release(self) -> None:
        """Write what is held up to the first ``Deferred`` still open."""
        held = self._held
        while held and not (isinstance(held[0], Deferred) and not held[0].closed):
            self._emit(held.popleft())

    def _deliver(self, env: Envelope) -> None:
        if self._held:
            self._write(env)
        else:
            for sink in self._sinks:
                sink.write(env)
        callbacks = self._subs.get(env.topic)
        if callbacks:
            self.stats.delivered[env.topic] = self.stats.delivered.get(env.topic, 0) + 1
            for cb in callbacks:
                cb(env.msg, env.time_ns)

    @property
    def sources_pending(self) -> bool:
        """True while a source still has a message waiting to be delivered."""
        return self._pending_sources > 0

    def stop(self) -> None:
        """Ask the run loop to end after the current event (Ctrl-C handling uses this)."""
        self._stopped = True

    def run(self, until_ns: int | None = None, on_step: Callable[[int], None] | None = None) -> None:
        """Process events in order until ``until_ns`` (inclusive) or until the sources run dry.

        With sources, timers alone do not keep the run going: it ends with the last recorded message.
        """
        queue = self._queue
        while queue and not self._stopped:
            t, rank, _seq, kind, payload = queue[0]
            if until_ns is not None and t > until_ns:
                break
            if self._sources and kind == "timer" and self._pending_sources == 0 and t > self.now:
                break  # the recording is over: timers at its last instant still fire, later ones do not
            heapq.heappop(queue)
            self.now = t
            if kind == "msg":
                self._deliver(payload)
            elif kind == "deferred":
                self._write(payload)
            elif kind == "source":
                index, env = payload
                while True:
                    self._pending_sources -= 1
                    self._deliver(env)
                    event = self._source_event(index)
                    if event is None:
                        break
                    # the source's next message, when it is the next event (before the queue's first: the
                    # keys differ in their sequence) and the loop would go on: delivered at once, unqueued
                    if (
                        on_step is None
                        and not self._stopped
                        and (until_ns is None or event[0] <= until_ns)
                        and (not queue or event < queue[0])
                    ):
                        self.now = event[0]
                        env = event[4][1]
                        continue
                    heapq.heappush(queue, event)
                    break
            else:
                timer = self._timers[payload]
                self.stats.timer_fires += 1
                self._push(t + timer.period_ns, timer.rank, "timer", payload)
                timer.callback(t)
            if on_step is not None:
                on_step(t)
        # deliver what is still in flight at the last time processed
        while self._queue and self._queue[0][3] in _OUTPUTS and self._queue[0][0] <= self.now:
            self._output(heapq.heappop(self._queue))

    def _output(self, event: tuple) -> None:
        if event[3] == "msg":
            self._deliver(event[4])
        else:
            self._write(event[4])

    def finish(self) -> None:
        """Let every node flush its final outputs (closing what it deferred), and deliver them."""
        for node in self._nodes:
            node.finish()
        while self._queue and self._queue[0][3] in _OUTPUTS:
            self._output(heapq.heappop(self._queue))
        self._release()
        if self._held:
            raise NavlogError(f"{len(self._held)} message(s) held behind outputs a node deferred and never gave")


_OUTPUTS = ("msg", "deferred")  # the events that are nodes' outputs
