"""The TF tree: every transform as an entity under ``tf/``, the fixed frame, and lookups into it.

The fixed frame is the option when given, else ``map`` when the tree has it (or has no frames),
else the root of the largest tree. Frames with no TF path to it are drawn as coincident with it.

A replay that publishes a frame's parent itself (a SLAM's or AMCL's map -> odom, in its replay.mcap) replaces
the log's transforms into that frame, as the replay itself ignored them (``TfTree.replaced``).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from navlog.analysis.view.context import ViewContext, entity_name
from navlog.replay import messages
from navlog.replay.runtime.tf import TFBuffer, TransformError, usable_norm


class TfTree:
    """/tf and /tf_static: a buffer for lookups, and every edge's samples for drawing."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.buffer = TFBuffer(cache_ns=1 << 62, frame_prefix=ctx.opt.frame_prefix, skipped=ctx.summary.skipped)
        self.edges: dict[tuple[str, str], dict] = {}  # (parent, child) -> static flag and samples
        # child frames whose transforms a replay's log gives (topics under ``replay_prefix``): the other logs'
        # transforms into them are left out and counted
        self.replaced: set[str] = set()
        self.replay_prefix = "replay/"

    def on_tf(self, topic: str, t: int, msg: Any) -> None:
        static = topic.endswith("/tf_static")
        if self.replaced and not topic.startswith(self.replay_prefix):
            kept = [ts for ts in msg.transforms if self.ctx.frame(ts.child_frame_id) not in self.replaced]
            if len(kept) < len(msg.transforms):
                frames = ", ".join(sorted(self.replaced))
                self.ctx.summary.skipped[f"{topic}: transforms into {frames} (the replay's own drawn instead)"] += len(
                    msg.transforms
                ) - len(kept)
                msg = messages.tf_message(kept)
        self.buffer.add_message(msg, static=static)
        for ts in msg.transforms:
            tr, r = ts.transform.translation, ts.transform.rotation
            if not usable_norm((tr.x, tr.y, tr.z), r.x, r.y, r.z, r.w):
                continue  # left out of the buffer above, and counted there
            parent, child = self.ctx.frame(ts.header.frame_id), self.ctx.frame(ts.child_frame_id)
            e = self.edges.setdefault((parent, child), {"static": static, "t": [], "xyz": [], "q": []})
            if static:
                e["static"] = True
                e["t"], e["xyz"], e["q"] = [t], [(tr.x, tr.y, tr.z)], [(r.x, r.y, r.z, r.w)]
            else:
                e["t"].append(t)
                e["xyz"].append((tr.x, tr.y, tr.z))
                e["q"].append((r.x, r.y, r.z, r.w))
        self.ctx.summary.drawn[topic] = "tf"

    # -------------------------------------------------------------- frames

    def choose_fixed_frame(self) -> None:
        """Set ``summary.fixed_frame`` (see the module doc)."""
        summary = self.ctx.summary
        if self.ctx.opt.fixed_frame:
            summary.fixed_frame = self.ctx.frame(self.ctx.opt.fixed_frame)
            return
        children = {c for _, c in self.edges}
        parents = {p for p, _ in self.edges}
        frames = children | parents
        if "map" in frames or not frames:
            summary.fixed_frame = "map"
            return
        roots = sorted(parents - children)
        size: Counter[str] = Counter()
        for r in roots:
            size[r] = sum(1 for f in frames if self.root_of(f) == r)
        summary.fixed_frame = max(roots, key=lambda r: (size[r], r == "odom", r)) if roots else "map"

    def base_frame(self) -> str | None:
        """The robot's base frame: base_footprint, else base_link, else None (no TF to the robot)."""
        frames = set(self.buffer.frames())
        return next((f for f in ("base_footprint", "base_link") if f in frames), None)

    def root_of(self, frame: str) -> str:
        parent = {c: p for p, c in self.edges}
        seen = set()
        while frame in parent and frame not in seen:
            seen.add(frame)
            frame = parent[frame]
        return frame

    def to_fixed(self, frame: str, stamp: int | None) -> np.ndarray | None:
        """Frame -> fixed frame at a stamp; a frame of another TF tree counts as coincident with it."""
        fixed = self.ctx.summary.fixed_frame
        try:
            return self.buffer.lookup(fixed, frame, stamp)
        except TransformError:
            root = self.root_of(frame)
            if root == self.root_of(fixed):
                return None
            try:
                return self.buffer.lookup(root, frame, stamp)
            except TransformError:
                return None

    # -------------------------------------------------------------- drawing

    def send(self) -> None:
        """Every edge as a Transform3D (static once, dynamic as columns) with unlabelled axes in its child
        frame. A dynamic edge that starts after the log does is held at its first sample from the log's
        start, so that nothing is drawn without a transform while the first edges arrive."""
        ctx, rr = self.ctx, self.ctx.rr
        for (parent, child), e in sorted(self.edges.items()):
            ent = ctx.entity(f"tf/{entity_name(child)}")
            xyz = np.asarray(e["xyz"], dtype=np.float64)
            q = np.asarray(e["q"], dtype=np.float64)
            if e["static"]:
                ctx.rec.log(
                    ent,
                    rr.Transform3D(
                        translation=xyz[-1],
                        quaternion=rr.Quaternion(xyzw=q[-1]),
                        parent_frame=parent,
                        child_frame=child,
                    ),
                    static=True,
                )
            else:
                times = list(e["t"])
                if times[0] > ctx.start_ns:
                    times.insert(0, ctx.start_ns)
                    xyz, q = np.vstack([xyz[:1], xyz]), np.vstack([q[:1], q])
                n = len(xyz)
                ctx.rec.send_columns(
                    ent,
                    indexes=[ctx.time_column(times)],
                    columns=rr.Transform3D.columns(
                        translation=xyz, quaternion=q, parent_frame=[parent] * n, child_frame=[child] * n
                    ),
                )
            axes = ctx.entity(f"tf/{entity_name(child)}/axes")
            ctx.set_frame(axes, child)
            ctx.rec.log(axes, rr.TransformAxes3D(0.15, show_frame=False), static=True)

    def link_orphan_frames(self) -> None:
        """Frames with no TF path to the fixed frame are drawn as coincident with it (and reported)."""
        ctx = self.ctx
        fixed = ctx.summary.fixed_frame
        fixed_root = self.root_of(fixed)
        orphans = sorted({self.root_of(f) for f in ctx.frames_used} - {fixed_root})
        for f in orphans:
            ent = ctx.entity(f"tf/_unlinked/{entity_name(f)}")
            ctx.rec.log(ent, ctx.rr.Transform3D(parent_frame=fixed, child_frame=f), static=True)
        if orphans:
            ctx.summary.warnings.append(
                f"frames without a TF path to {fixed}, drawn as coincident with it: {', '.join(orphans)}"
            )
