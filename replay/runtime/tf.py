"""A TF buffer: static and dynamic transforms, lookups with interpolation in time.

Frames form a tree; ``lookup(target, source, t_ns)`` returns the 4x4 matrix that maps points in
``source`` into ``target`` at time ``t_ns``, interpolating each dynamic edge between its two
nearest samples (linear translation, slerp rotation). A time outside an edge's buffered range
raises ``TransformError`` (no extrapolation), which callers count as a skipped message.
The frames between two frames, and each static edge's matrix, are computed once and kept until the
tree changes; each dynamic edge keeps its matrix at the time it was last asked for, for the next lookup
at that time in the same ``epoch`` (a command and a scan stamped alike share their edges); a lookup's
matrix is always the caller's own.

``lookup_pose`` gives a lookup's transform as a ``Pose`` of plain floats (translation, unit quaternion),
composed in floats (``compose_poses``, ``relative_pose``): the matrix's transform to rounding, not to the
bit, for a caller that only needs a bound; it fails exactly where ``lookup`` fails.

A caller may keep a lookup's result while the buffer would give it unchanged (``holds``): a lookup at
``t`` interpolated between samples around ``t`` on each dynamic edge of its chain, and appending a
sample newer than an edge's newest changes none of those. Anything else (a static transform, a new or
re-parented edge, a sample at or before an edge's newest stamp) starts a new ``epoch``; ``added``
counts the transforms added (a lookup of the latest transforms holds while it is the same).

A transform with a coordinate that is not finite or farther than ``MAX_TRANSLATION_M``, or a rotation whose
length is zero or overflows, is not added: it is counted in the ``skipped`` counter the buffer was given (a node's), one reason per
edge, named for ``topic`` (by default /tf or /tf_static). A rotation of any other length is normalised.
"""

from __future__ import annotations

import bisect
import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.geometry import quat_norm, slerp, unit_quat_transform
from navlog.replay.limits import MAX_TRANSLATION_M


class TransformError(NavlogError):
    """No transform between two frames at the asked time."""


# a rigid transform as plain floats: translation x, y, z and unit quaternion x, y, z, w
Pose = tuple[float, float, float, float, float, float, float]
IDENTITY_POSE: Pose = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def compose_poses(a: Pose, b: Pose) -> Pose:
    """``a`` after ``b`` (the pose of ``b``'s frame in ``a``'s parent), in floats."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    # b's translation rotated by a's quaternion: v + 2w (u x v) + 2 u x (u x v)
    cx, cy, cz = qy * bz - qz * by, qz * bx - qx * bz, qx * by - qy * bx
    dx, dy, dz = qy * cz - qz * cy, qz * cx - qx * cz, qx * cy - qy * cx
    return (
        ax + bx + 2.0 * (qw * cx + dx),
        ay + by + 2.0 * (qw * cy + dy),
        az + bz + 2.0 * (qw * cz + dz),
        qw * rx + qx * rw + qy * rz - qz * ry,
        qw * ry - qx * rz + qy * rw + qz * rx,
        qw * rz + qx * ry - qy * rx + qz * rw,
        qw * rw - qx * rx - qy * ry - qz * rz,
    )


def invert_pose(a: Pose) -> Pose:
    """The inverse rigid transform of ``a``, in floats."""
    return relative_pose(a, IDENTITY_POSE)


def relative_pose(a: Pose, b: Pose) -> Pose:
    """``a``'s inverse after ``b``: the pose of ``b``'s frame in ``a``'s (both given in one parent), in floats."""
    ax, ay, az, qx, qy, qz, qw = a
    return compose_poses((0.0, 0.0, 0.0, -qx, -qy, -qz, qw), (b[0] - ax, b[1] - ay, b[2] - az, *b[3:]))


@dataclass
class _Edge:
    parent: str
    static: bool
    times: list[int] = field(default_factory=list)
    trans: list[tuple[float, float, float]] = field(default_factory=list)
    quats: list[tuple[float, float, float, float]] = field(default_factory=list)  # unit, x y z w
    # samples before index ``start`` have left the cache: they are removed from the lists in batches
    start: int = 0
    matrix: np.ndarray | None = None  # a static edge's matrix, once computed (read-only)
    # a dynamic edge's last matrix (read-only): (time, the buffer's epoch then, matrix)
    last: tuple[int, int, np.ndarray] | None = None


def usable_norm(p: tuple, x: float, y: float, z: float, w: float) -> float:
    """The norm of a transform's quaternion (x, y, z, w) where the transform is usable -- every coordinate of
    ``p`` within ``MAX_TRANSLATION_M`` (so finite) and that norm positive and finite (``geometry.quat_norm``) --
    else 0.0: what the buffer leaves out and counts, and what a drawing of the samples leaves out with it."""
    n = quat_norm(x, y, z, w)
    near = abs(p[0]) <= MAX_TRANSLATION_M and abs(p[1]) <= MAX_TRANSLATION_M and abs(p[2]) <= MAX_TRANSLATION_M
    return n if 0.0 < n < math.inf and near else 0.0


class TFBuffer:
    def __init__(
        self,
        cache_ns: int = 10_000_000_000,
        frame_prefix: str = "",
        skipped: Counter[str] | None = None,
        topic: str | None = None,
    ) -> None:
        self.cache_ns = cache_ns
        self.skipped = Counter() if skipped is None else skipped  # transforms not added, by reason
        self.topic = topic
        self.frame_prefix = frame_prefix
        self._edges: dict[str, _Edge] = {}  # keyed by child frame
        self._names: dict[str, str] = {}  # frame id as given -> as stored
        self._chains: dict[str, list[str]] = {}  # frame -> it and its ancestors, while the tree is unchanged
        # (target, source) as given -> the frames from each up to their common ancestor, while the tree is unchanged
        self._paths: dict[tuple[str, str], tuple[list[str], list[str]]] = {}
        self.epoch = 0  # see the module docstring
        self.added = 0  # transforms added
        self.newest: int | None = None  # the newest dynamic stamp added

    def _name(self, frame: str) -> str:
        name = self._names.get(frame)
        if name is None:
            f = frame.lstrip("/")
            if self.frame_prefix and f.startswith(self.frame_prefix):
                f = f[len(self.frame_prefix) :]
            name = self._names[frame] = f
        return name

    def add_message(self, msg: Any, static: bool = False) -> None:
        """Add every transform of a tf2_msgs/TFMessage (a message object or ``messages.TFTransforms``)."""
        self.add_message_skipping(msg, static, None)

    def add_message_skipping(self, msg: Any, static: bool, skip_child: str | None) -> int:
        """Add every transform of a tf2_msgs/TFMessage except those into ``skip_child`` (a frame whose
        parent the caller publishes itself, e.g. a localiser's odom frame); returns how many were skipped."""
        skipped = 0
        known, name, insert = self._names.get, self._name, self._insert
        for parent, child, t_ns, tx, ty, tz, qx, qy, qz, qw in messages.tf_entries(msg):
            child = known(child) or name(child)  # (a name stored as "" is looked up again: "" again)
            if child == skip_child:
                skipped += 1
                continue
            # a message's fields are floats
            insert(known(parent) or name(parent), child, t_ns, (tx, ty, tz), qx, qy, qz, qw, static)
        return skipped

    def add(self, parent: str, child: str, t_ns: int, xyz, q_xyzw, static: bool = False) -> None:
        """Add one transform: ``xyz`` and ``q_xyzw`` (normalised here) as any numbers."""
        x, y, z, w = q_xyzw
        p = (float(xyz[0]), float(xyz[1]), float(xyz[2]))
        self._insert(parent, child, t_ns, p, float(x), float(y), float(z), float(w), static)

    def _insert(
        self, parent: str, child: str, t_ns: int, p: tuple, x: float, y: float, z: float, w: float, static: bool
    ) -> None:
        n = usable_norm(p, x, y, z, w)
        if not n:
            topic = self.topic or ("/tf_static" if static else "/tf")
            self.skipped[
                f"{topic}: transform {parent} -> {child} not finite, farther than {MAX_TRANSLATION_M:g} m or with a zero rotation "
                "(ignored)"
            ] += 1
            return
        self.added += 1
        edge = self._edges.get(child)
        if edge is None or edge.parent != parent or edge.static != static:
            edge = _Edge(parent, static)
            self._edges[child] = edge
            self._chains.clear()
            self._paths.clear()
            self.epoch += 1
        q = (x / n, y / n, z / n, w / n)
        if static:
            edge.times, edge.trans, edge.quats, edge.start, edge.matrix = [0], [p], [q], 0, None
            self.epoch += 1
            return
        if self.newest is None or t_ns > self.newest:
            self.newest = t_ns
        times, start = edge.times, edge.start
        if not times or t_ns > times[-1]:  # the usual case: a newer sample
            times.append(t_ns)
            edge.trans.append(p)
            edge.quats.append(q)
        else:
            self.epoch += 1  # a sample inside the edge's history: interpolations may change
            i = bisect.bisect_right(times, t_ns, start)
            if i > start and times[i - 1] == t_ns:
                edge.trans[i - 1], edge.quats[i - 1] = p, q
                return
            times.insert(i, t_ns)
            edge.trans.insert(i, p)
            edge.quats.insert(i, q)
        cutoff = times[-1] - self.cache_ns
        if times[start + 1 if len(times) - start > 1 else start] >= cutoff:
            return  # nothing to drop (the usual case: a sample is dropped once the one after it is too old)
        keep = bisect.bisect_left(times, cutoff, start) - 1  # the last sample at or before the cutoff stays
        if keep > start:
            if keep > len(times) // 2:  # remove the dropped samples once they are half the lists
                del times[:keep], edge.trans[:keep], edge.quats[:keep]
                keep = 0
            edge.start = keep

    def holds(self, epoch: int, t_ns: int) -> bool:
        """Whether a lookup at ``t_ns`` that succeeded at ``epoch`` gives the same transform now."""
        return epoch == self.epoch and (self.newest is None or t_ns >= self.newest - self.cache_ns)

    def name(self, frame: str) -> str:
        """A frame's name as the buffer stores it (leading slash and prefix removed)."""
        return self._name(frame)

    def static_between(self, frame: str, ancestor: str) -> bool:
        """True if every edge from ``frame`` up to ``ancestor`` (or the root) is static."""
        f = self._name(frame)
        while f in self._edges and f != ancestor:
            if not self._edges[f].static:
                return False
            f = self._edges[f].parent
        return True

    def time_range(self, child: str) -> tuple[int, int] | None:
        """First and last stamp buffered for the edge into ``child`` (None when there is none)."""
        e = self._edges.get(self._name(child))
        return (e.times[e.start], e.times[-1]) if e is not None and e.times else None

    def frames(self) -> list[str]:
        out = set(self._edges)
        out.update(e.parent for e in self._edges.values())
        return sorted(out)

    @staticmethod
    def _outside(e: _Edge, child: str, t_ns: int) -> TransformError:
        times = e.times
        return TransformError(
            f"no transform {e.parent} -> {child} at {t_ns / 1e9:.3f} s "
            f"(buffer holds {times[e.start] / 1e9:.3f}..{times[-1] / 1e9:.3f} s)"
        )

    @staticmethod
    def _sample(e: _Edge, t_ns: int) -> tuple[Any, Any] | int:
        """A dynamic edge at ``t_ns`` within its samples: the index of a sample at ``t_ns``, else the
        translation and the quaternion (slerp, an array) interpolated between the two around it."""
        times = e.times
        if t_ns == times[-1]:  # the usual ask: the newest sample
            return len(times) - 1
        i = bisect.bisect_left(times, t_ns, e.start)
        if times[i] == t_ns:
            return i
        t0, t1 = times[i - 1], times[i]
        a = (t_ns - t0) / (t1 - t0)
        p0, p1 = e.trans[i - 1], e.trans[i]
        xyz = ((1 - a) * p0[0] + a * p1[0], (1 - a) * p0[1] + a * p1[1], (1 - a) * p0[2] + a * p1[2])
        return xyz, slerp(np.array(e.quats[i - 1]), np.array(e.quats[i]), a)

    def _edge_matrix(self, child: str, t_ns: int | None) -> np.ndarray:
        e = self._edges[child]
        if e.static:
            if e.matrix is None:
                e.matrix = unit_quat_transform(e.trans[-1], e.quats[-1])
                e.matrix.flags.writeable = False
            return e.matrix
        times = e.times
        if t_ns is None:
            t_ns = times[-1]
        elif t_ns < times[e.start] or t_ns > times[-1]:
            raise self._outside(e, child, t_ns)
        # the same time again with the same samples around it (no new epoch): the same matrix
        last = e.last
        if last is not None and last[0] == t_ns and last[1] == self.epoch:
            return last[2]
        at = self._sample(e, t_ns)
        m = unit_quat_transform(e.trans[at], e.quats[at]) if isinstance(at, int) else unit_quat_transform(*at)
        m.flags.writeable = False
        e.last = (t_ns, self.epoch, m)
        return m

    def _edge_pose(self, child: str, t_ns: int | None) -> Pose:
        """``_edge_matrix``'s transform as a ``Pose`` of floats (the same samples, the same errors)."""
        e = self._edges[child]
        if e.static:
            return (*e.trans[-1], *e.quats[-1])
        times = e.times
        if t_ns is None:
            t_ns = times[-1]
        elif t_ns < times[e.start] or t_ns > times[-1]:
            raise self._outside(e, child, t_ns)
        at = self._sample(e, t_ns)
        if isinstance(at, int):
            return (*e.trans[at], *e.quats[at])
        return (*at[0], *at[1].tolist())

    def _chain(self, frame: str) -> list[str]:
        chain = self._chains.get(frame)
        if chain is None:
            chain = self._chains[frame] = self._walk_up(frame)
        return chain

    def _walk_up(self, frame: str) -> list[str]:
        chain = [frame]
        seen = {frame}
        while frame in self._edges:
            frame = self._edges[frame].parent
            if frame in seen:
                raise TransformError(f"TF loop through {frame}")
            seen.add(frame)
            chain.append(frame)
        return chain

    def lookup(self, target: str, source: str, t_ns: int | None) -> np.ndarray:
        """4x4 transform taking points in ``source`` to ``target`` at ``t_ns`` (None: latest)."""
        path = self._paths.get((target, source))
        if path is None:
            path = self._path(target, source)
        m_s = self._to_ancestor(path[0], t_ns)  # source -> common
        m_t = self._to_ancestor(path[1], t_ns)  # target -> common
        if m_t is None:
            return np.eye(4) if m_s is None else m_s
        m_t = np.linalg.inv(m_t)
        return m_t if m_s is None else m_t @ m_s

    def lookup_pose(self, target: str, source: str, t_ns: int | None) -> Pose:
        """``lookup``'s transform as a ``Pose`` of plain floats, composed in floats: equal to ``lookup``'s
        matrix to rounding (not to the bit), for tests whose margins cover rounding. It raises exactly
        when ``lookup`` does (the same edges, the same samples)."""
        path = self._paths.get((target, source))
        if path is None:
            path = self._path(target, source)
        up_s, up_t = (self._pose_to_ancestor(frames, t_ns) for frames in path)
        if up_t is None:
            return IDENTITY_POSE if up_s is None else up_s
        return relative_pose(up_t, IDENTITY_POSE if up_s is None else up_s)

    def _pose_to_ancestor(self, frames: list[str], t_ns: int | None) -> Pose | None:
        """``_to_ancestor`` as a ``Pose`` of floats."""
        out = None
        for f in frames:
            pose = self._edge_pose(f, t_ns)
            out = pose if out is None else compose_poses(pose, out)
        return out

    def _path(self, target: str, source: str) -> tuple[list[str], list[str]]:
        """The frames from ``source`` and from ``target`` up to (not including) their common ancestor,
        kept while the tree is unchanged."""
        t_name, s_name = self._name(target), self._name(source)
        if t_name == s_name:
            path: tuple[list[str], list[str]] = ([], [])
        else:
            up_s, up_t = self._chain(s_name), self._chain(t_name)
            common = next((f for f in up_s if f in set(up_t)), None)
            if common is None:
                raise TransformError(
                    f"frames {s_name} and {t_name} are not connected "
                    f"(known frames: {', '.join(self.frames()) or 'none'})"
                )
            path = (up_s[: up_s.index(common)], up_t[: up_t.index(common)])
        self._paths[(target, source)] = path
        return path

    def _to_ancestor(self, frames: list[str], t_ns: int | None) -> np.ndarray | None:
        """The product of the edge matrices from the first of ``frames`` up to the last one's parent;
        None for no edge (the identity, so that no product with it is computed)."""
        out = None
        for f in frames:
            m = self._edge_matrix(f, t_ns)
            out = m if out is None else m @ out
        if out is not None and len(frames) == 1 and not out.flags.writeable:
            out = out.copy()  # an edge's kept matrix: the caller gets its own
        return out

    def latest_common_time(self, target: str, source: str) -> int | None:
        """The newest time at which every dynamic edge between the two frames has a sample at or after
        it (the latest time ``lookup`` can interpolate at, given its start); None when the frames are
        not connected or only static edges join them."""
        path = self._paths.get((target, source))
        if path is None:
            try:
                path = self._path(target, source)
            except TransformError:
                return None
        edges = self._edges
        latest = None
        for frames in path:
            for f in frames:
                e = edges[f]
                if not e.static and (latest is None or e.times[-1] < latest):
                    latest = e.times[-1]
        return latest

    def connected(self, a: str, b: str) -> bool:
        """Whether frames ``a`` and ``b`` are in one tree (at some time)."""
        try:
            self._path(a, b)
            return True
        except TransformError:
            return False

    def can_transform(self, target: str, source: str, t_ns: int | None) -> bool:
        try:
            self.lookup(target, source, t_ns)
            return True
        except TransformError:
            return False


class WaitingForTransforms:
    """Messages that wait, in arrival order, until what they need at their header stamp is known (a pose,
    a transform), as tf2's message filter holds a scan until its transform arrives.

    ``drain`` hands each waiting message, oldest first, to ``resolve(msg, stamp)``; a ``TransformError``
    keeps it (and those after it) waiting, unless it is ``final``, older than ``timeout_ns`` before the
    newest stamp waiting, or ``hopeless(stamp)``: then ``drop(msg, stamp)`` is told and the next one
    tried. Time is the messages' own stamps, never the log's receive time (real bags can stamp headers
    in sim time and receive in wall time).
    """

    def __init__(self, timeout_ns: int) -> None:
        self.timeout_ns = timeout_ns
        self.items: list[Any] = []

    def push(self, msg: Any) -> None:
        self.items.append(msg)

    def drain(
        self,
        resolve: Callable[[Any, int], Any],
        use: Callable[[Any, int, Any], None],
        drop: Callable[[Any, int], None],
        *,
        final: bool = False,
        hopeless: Callable[[int], bool] | None = None,
    ) -> None:
        items = self.items
        newest = messages.to_ns(items[-1].header.stamp) if items else 0
        while items:
            msg = items[0]
            stamp = messages.to_ns(msg.header.stamp)
            try:
                found = resolve(msg, stamp)
            except TransformError:
                if final or newest - stamp > self.timeout_ns or (hopeless is not None and hopeless(stamp)):
                    items.pop(0)
                    drop(msg, stamp)
                    continue
                return
            items.pop(0)
            use(msg, stamp, found)
