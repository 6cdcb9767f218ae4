"""The pieces of static geometry a world is made of (``Solid``), in the world frame."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Solid:
    """One piece of static geometry in the world frame.

    A ``mesh`` is triangles in the world frame (``vertices``: x, y, z of each vertex; ``faces``: three
    vertex indices per triangle), one connected piece; ``center`` and ``size`` are its bounding box.
    ``convex``: it is its own convex hull (MuJoCo, which collides a mesh by its hull, collides it
    exactly; any other mesh collides as one thin slab per triangle). ``closed``: every edge joins two
    triangles, so the mesh has an inside (which counts as occupied)."""

    name: str
    shape: str  # box | cylinder | mesh
    center: tuple[float, float, float]
    yaw: float
    size: tuple[float, float, float]  # box: full sizes; cylinder: (2r, 2r, height); mesh: bounding box
    vertices: tuple[float, ...] = ()
    faces: tuple[int, ...] = ()
    convex: bool = False
    closed: bool = False

    @property
    def z_range(self) -> tuple[float, float]:
        return self.center[2] - self.size[2] / 2, self.center[2] + self.size[2] / 2

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """A mesh's vertices (n, 3) and faces (m, 3) as arrays."""
        return np.asarray(self.vertices, dtype=np.float64).reshape(-1, 3), np.asarray(self.faces, np.int64).reshape(
            -1, 3
        )

    def footprint_box(self) -> tuple[float, float, float, float]:
        """xmin, ymin, xmax, ymax of the solid seen from above."""
        c, s = abs(math.cos(self.yaw)), abs(math.sin(self.yaw))
        hx = (c * self.size[0] + s * self.size[1]) / 2
        hy = (s * self.size[0] + c * self.size[1]) / 2
        return self.center[0] - hx, self.center[1] - hy, self.center[0] + hx, self.center[1] + hy


def mesh_solid(name: str, vertices: np.ndarray, faces: np.ndarray) -> Solid:
    """A ``mesh`` Solid of one connected piece of triangles in the world frame."""
    from navlog.recorder.meshes import is_closed, is_convex

    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return Solid(
        name,
        "mesh",
        tuple(float(v) for v in (lo + hi) / 2),  # type: ignore[arg-type]
        0.0,
        tuple(float(v) for v in hi - lo),  # type: ignore[arg-type]
        tuple(vertices.reshape(-1).tolist()),
        tuple(int(v) for v in faces.reshape(-1)),
        is_convex(vertices, faces),
        is_closed(faces),
    )
