"""TF coverage: over what share of a time span a chain of frames (``map`` -> ``base_link``) is available.

The TF tree is built from the edges a log's /tf and /tf_static carry (each child frame has one parent).
A chain is the path of edges between two frames through their nearest common ancestor. A static edge
covers all time; a dynamic edge covers the stretch between two consecutive stamps no further apart
than ``max_gap_ns`` (a TF buffer interpolates there, and nowhere else: no extrapolation). The chain is
available where all its edges are; coverage is the length of that, within the span, over the span.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

Intervals = list[tuple[int, int]]


@dataclass(frozen=True)
class ChainCoverage:
    target: str
    source: str
    chain: list[str]  # the edges, "parent->child", from target (up to the common ancestor, down) to source
    coverage: float  # share of the span, 0..1
    covered_ns: int
    largest_hole: tuple[int, int] | None  # the longest stretch of the span without the chain


def tf_tree(edges: Iterable[tuple[str, str, int]]) -> dict[str, str]:
    """child -> parent, from (parent, child, samples) edges; a child with two parents keeps the busier one."""
    best: dict[str, tuple[int, str]] = {}
    for parent, child, samples in sorted(edges):
        if child not in best or samples > best[child][0]:
            best[child] = (samples, parent)
    return {child: parent for child, (_, parent) in best.items()}


def _ancestors(tree: Mapping[str, str], frame: str) -> list[str]:
    out = [frame]
    while out[-1] in tree and tree[out[-1]] not in out:
        out.append(tree[out[-1]])
    return out


def chain_edges(tree: Mapping[str, str], target: str, source: str) -> list[tuple[str, str]] | None:
    """The (parent, child) edges joining ``source`` to ``target``, or None when they are not connected."""
    up_source, up_target = _ancestors(tree, source), _ancestors(tree, target)
    common = next((f for f in up_source if f in set(up_target)), None)
    if common is None:
        return None
    # from target up to the common ancestor, then down to source
    path = up_target[: up_target.index(common)] + up_source[: up_source.index(common)][::-1]
    return [(tree[f], f) for f in path]


def covered(stamps: Sequence[int] | np.ndarray, max_gap_ns: int) -> Intervals:
    """The stretches between consecutive stamps at most ``max_gap_ns`` apart, merged."""
    t = np.unique(np.asarray(stamps, dtype=np.int64))
    if t.size < 2:
        return []
    ok = np.diff(t) <= max_gap_ns
    out: Intervals = []
    for i in np.flatnonzero(ok):
        start, end = int(t[i]), int(t[i + 1])
        if out and out[-1][1] == start:
            out[-1] = (out[-1][0], end)
        else:
            out.append((start, end))
    return out


def intersect(a: Intervals, b: Intervals) -> Intervals:
    """Where two sorted, disjoint interval lists overlap."""
    out: Intervals = []
    i = j = 0
    while i < len(a) and j < len(b):
        start, end = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if start < end:
            out.append((start, end))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def chain_coverage(
    edges: Mapping[tuple[str, str], tuple[bool, Sequence[int] | np.ndarray]],
    target: str,
    source: str,
    span: tuple[int, int],
    max_gap_ns: int,
) -> ChainCoverage:
    """Coverage of ``target`` -> ``source`` over ``span``; ``edges``: (parent, child) -> (static, stamps)."""
    tree = tf_tree((p, c, len(stamps)) for (p, c), (_, stamps) in edges.items())
    chain = chain_edges(tree, target, source)
    whole: Intervals = [span] if span[1] > span[0] else []
    if chain is None:
        return ChainCoverage(target, source, [], 0.0, 0, whole[0] if whole else None)
    avail = whole
    for key in chain:
        static, stamps = edges[key]
        if not static:
            avail = intersect(avail, covered(stamps, max_gap_ns))
    length = span[1] - span[0]
    got = sum(e - s for s, e in avail)
    holes = intersect(whole, _complement(avail, span))
    hole = max(holes, key=lambda h: (h[1] - h[0], -h[0]), default=None)
    return ChainCoverage(
        target,
        source,
        [f"{p}->{c}" for p, c in chain],
        got / length if length > 0 else 1.0,
        got,
        hole,
    )


def _complement(avail: Intervals, span: tuple[int, int]) -> Intervals:
    out: Intervals = []
    at = span[0]
    for s, e in avail:
        if s > at:
            out.append((at, s))
        at = max(at, e)
    if at < span[1]:
        out.append((at, span[1]))
    return out
