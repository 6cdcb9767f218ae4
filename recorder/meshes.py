"""Triangle meshes as world geometry: reading mesh files, splitting them into pieces, and their footprints.

- ``read_mesh_file`` reads a DAE, STL, OBJ, PLY... file with trimesh (and pycollada for DAE), in
  metres (a COLLADA file's ``<unit meter=...>`` applied, as Gazebo applies it), scaled by ``scale``.
- ``split_components`` splits a mesh into its connected pieces (vertices shared by position), so
  that each piece of a world mesh becomes its own solid: MuJoCo collides a mesh geom by its convex
  hull, and the hull of separate pillars in one file would join them.
- ``is_convex`` says whether a piece is its own convex hull (then MuJoCo collides it exactly);
  ``triangle_prisms`` gives, for a piece that is not (a ring of walls, whose hull would fill the
  room), one thin convex prism per triangle: the collision shape of the surface itself.
- ``footprint_distance`` is the horizontal distance from points to what a mesh covers between two
  heights (negative inside), for the ground-truth grid and the clearance checks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navlog.errors import ConfigError

PRISM_THICKNESS = 0.02  # m, the collision slab of each triangle of a mesh that is not convex
MERGE_DECIMALS = 6  # vertices closer than a micrometre are one vertex when splitting
_POINT_CHUNK = 4_000_000  # points x segments per block of the crossing count


def read_mesh_file(path: Path, scale: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of the mesh file ``path``: vertices (n, 3) in metres times ``scale``, faces (m, 3).

    ConfigError when the file cannot be read or holds no triangle."""
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="scene")
    except Exception as exc:  # trimesh and its readers raise many kinds
        raise ConfigError(f"{path}: cannot read the mesh ({type(exc).__name__}: {exc})") from None
    mesh = loaded.to_geometry() if isinstance(loaded, trimesh.Scene) else loaded
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ConfigError(f"{path}: the mesh holds no triangle")
    unit = 1.0
    if loaded.units not in (None, "", "meters", "m"):
        try:
            unit = float(trimesh.units.unit_conversion(loaded.units, "meters"))
        except Exception:
            unit = 1.0
    vertices = np.asarray(mesh.vertices, dtype=np.float64) * unit * np.asarray(scale, dtype=np.float64)
    return vertices, np.asarray(mesh.faces, dtype=np.int64)


def split_components(vertices: np.ndarray, faces: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The connected pieces of a mesh (faces joined by vertices at the same position), each with
    its own vertices and faces; a mesh of one piece comes back whole (with merged vertices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    keys = np.round(vertices, MERGE_DECIMALS)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    merged = inverse.reshape(-1)[faces]
    n = len(unique)
    rows = np.repeat(merged[:, 0], 2)
    cols = merged[:, 1:].reshape(-1)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    pieces = []
    face_labels = labels[merged[:, 0]]
    for k in range(count):
        f = merged[face_labels == k]
        if len(f) == 0:
            continue
        used, local = np.unique(f, return_inverse=True)
        pieces.append((unique[used].astype(np.float64), local.reshape(-1, 3)))
    return pieces


def is_convex(vertices: np.ndarray, faces: np.ndarray, tolerance: float = 1e-4) -> bool:
    """True when every triangle lies on the surface of the piece's convex hull (the piece is its hull)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return False  # flat or degenerate: no volume
    centroids = vertices[faces].mean(axis=1)
    # signed distances of each centroid to every hull plane (<= 0 inside); on the surface: max ~ 0
    dist = centroids @ hull.equations[:, :3].T + hull.equations[:, 3]
    return bool(np.all(dist.max(axis=1) > -tolerance))


def triangle_prisms(vertices: np.ndarray, faces: np.ndarray, thickness: float = PRISM_THICKNESS) -> list[np.ndarray]:
    """One convex prism per triangle (6 vertices: the triangle moved half ``thickness`` along its normal
    both ways), skipping triangles without area."""
    tri = vertices[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1)
    keep = length > 1e-9
    offset = normal[keep] / length[keep, None] * (thickness / 2)
    return [np.concatenate([t + o, t - o]) for t, o in zip(tri[keep], offset)]


def _clip_band(tri: np.ndarray, z0: float, z1: float) -> list[np.ndarray]:
    """The parts of each triangle (k, 3, 3) between heights z0 and z1, as polygons (xy points)."""
    out = []
    for poly in tri:
        pts = list(poly)
        for limit, keep_below in ((z1, True), (z0, False)):
            clipped = []
            for i, a in enumerate(pts):
                b = pts[(i + 1) % len(pts)]
                a_in = a[2] <= limit if keep_below else a[2] >= limit
                b_in = b[2] <= limit if keep_below else b[2] >= limit
                if a_in:
                    clipped.append(a)
                if a_in != b_in:
                    t = (limit - a[2]) / (b[2] - a[2])
                    cut = a + t * (b - a)
                    cut[2] = limit  # exactly: a band of no height keeps it
                    clipped.append(cut)
            pts = clipped
            if not pts:
                break
        if pts:
            out.append(np.asarray(pts)[:, :2])
    return out


def _section_segments(tri: np.ndarray, z: float) -> np.ndarray:
    """The segments (k, 2, 2) where the triangles (m, 3, 3) cross height ``z``."""
    d = tri[:, :, 2] - z
    above = d > 0
    crossing = above.any(axis=1) & ~above.all(axis=1)
    segs = []
    for t, dz in zip(tri[crossing], d[crossing]):
        pts = []
        for i in range(3):
            a, b, da, db = t[i], t[(i + 1) % 3], dz[i], dz[(i + 1) % 3]
            if (da > 0) != (db > 0):
                pts.append((a + da / (da - db) * (b - a))[:2])
        if len(pts) == 2:
            segs.append(pts)
    return np.asarray(segs, dtype=np.float64).reshape(-1, 2, 2)


def _segment_distance(pts: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to the nearest segment (k, 2, 2)."""
    best = np.full(len(pts), np.inf)
    px, py = pts[:, 0], pts[:, 1]
    for (ax, ay), (bx, by) in seg:
        dx, dy = bx - ax, by - ay
        t = np.clip(((px - ax) * dx + (py - ay) * dy) / max(dx * dx + dy * dy, 1e-18), 0.0, 1.0)
        ex, ey = px - (ax + t * dx), py - (ay + t * dy)
        np.minimum(best, ex * ex + ey * ey, out=best)
    return np.sqrt(best)


def _crossings_odd(pts: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Even-odd rule: whether a ray from each point towards +x crosses the segments an odd number of times."""
    inside = np.zeros(len(pts), dtype=bool)
    if len(seg) == 0:
        return inside
    step = max(1, _POINT_CHUNK // len(seg))
    (x1, y1), (x2, y2) = seg[:, 0].T, seg[:, 1].T
    for i in range(0, len(pts), step):
        px, py = pts[i : i + step, 0:1], pts[i : i + step, 1:2]
        straddle = (y1 > py) != (y2 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside[i : i + step] = ((straddle & (xc > px)).sum(axis=1) % 2) == 1
    return inside


def _inside_polygons(pts: np.ndarray, polygons: list[np.ndarray]) -> np.ndarray:
    """Whether each point lies in one of the convex polygons (either winding)."""
    inside = np.zeros(len(pts), dtype=bool)
    for poly in polygons:
        if len(poly) < 3:
            continue
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        near = np.flatnonzero(np.all((pts >= lo) & (pts <= hi), axis=1) & ~inside)
        if len(near) == 0:
            continue
        e = np.roll(poly, -1, axis=0) - poly
        rel = pts[near, None, :] - poly[None]
        cross = e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]
        hit = np.all(cross >= -1e-12, axis=1) | np.all(cross <= 1e-12, axis=1)
        inside[near[hit]] = True
    return inside


def footprint_distance(
    vertices: np.ndarray, faces: np.ndarray, closed: bool, pts: np.ndarray, z0: float, z1: float
) -> np.ndarray | None:
    """Horizontal distance from each point (n, 2) to what the mesh covers between heights z0 and z1:
    negative inside, None when the mesh does not reach into those heights.

    What a mesh covers in a band is the projection of its triangles clipped to the band, and, for a
    closed mesh, the inside of its cross-section at one height of the band (a point inside at another
    height lies under a clipped triangle: going up or down to that height crosses the surface)."""
    zs = vertices[:, 2]
    lo, hi = max(z0, float(zs.min())), min(z1, float(zs.max()))
    if lo > hi:
        return None
    tri = vertices[faces]
    polygons = _clip_band(tri, z0, z1)
    edges = [np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in polygons]
    section = np.zeros((0, 2, 2))
    if closed and hi > lo:
        mid = 0.5 * (lo + hi)
        levels = np.unique(zs)
        if np.any(np.isclose(levels, mid, atol=1e-9)):  # a height between vertex heights
            mid = lo + 0.5 * (mid - lo)
        section = _section_segments(tri, mid)
    segments = np.concatenate([*edges, section]) if edges or len(section) else np.zeros((0, 2, 2))
    dist = _segment_distance(pts, segments)
    inside = _inside_polygons(pts, polygons)
    if len(section):
        inside |= _crossings_odd(pts, section)
    return np.where(inside, -dist, dist)


def is_closed(faces: np.ndarray) -> bool:
    """True when every edge of the (vertex-merged) mesh is shared by exactly two triangles."""
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool(len(counts) and np.all(counts == 2))


# ---------------------------------------------------------------- extruded polygons (SDF <polyline>)


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) / 2.0


def _inside(point: np.ndarray, ring: np.ndarray) -> bool:
    """Whether ``point`` lies inside the polygon ``ring`` (crossing count)."""
    x, y = float(point[0]), float(point[1])
    inside = False
    for (x0, y0), (x1, y1) in zip(ring.tolist(), np.roll(ring, -1, axis=0).tolist(), strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def _crosses(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> bool:
    """Whether the segments ab and cd cross at a point inside both (touching ends do not count)."""

    def side(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    d1, d2, d3, d4 = side(a, b, c), side(a, b, d), side(c, d, a), side(c, d, b)
    return d1 * d2 < 0 and d3 * d4 < 0


def _bridged(outer: np.ndarray, holes: list[np.ndarray]) -> np.ndarray:
    """One ring of the outer ring (counter-clockwise) and its holes (clockwise), each hole joined to the
    outer ring by a bridge there and back from its vertex with the largest x to the nearest outer vertex
    the bridge reaches without crossing an edge."""
    ring = outer
    for hole in sorted(holes, key=lambda h: -float(h[:, 0].max())):
        m = int(np.argmax(hole[:, 0]))
        edges = [(r[i], r[(i + 1) % len(r)]) for r in [ring, *holes] for i in range(len(r))]
        order = np.argsort(np.hypot(*(ring - hole[m]).T))
        p = next((int(i) for i in order if not any(_crosses(hole[m], ring[i], a, b) for a, b in edges)), int(order[0]))
        loop = np.roll(hole, -m, axis=0)
        ring = np.concatenate([ring[: p + 1], loop, loop[:1], ring[p:]])
    return ring


def _ear_clip(ring: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles (indices into ``ring``, counter-clockwise) of a simple counter-clockwise polygon."""
    idx = list(range(len(ring)))
    out: list[tuple[int, int, int]] = []

    def cross(i: int, j: int, k: int) -> float:
        a, b, c = ring[i], ring[j], ring[k]
        return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    def contains(i: int, j: int, k: int, p: int) -> bool:
        if np.allclose(ring[p], ring[i]) or np.allclose(ring[p], ring[j]) or np.allclose(ring[p], ring[k]):
            return False
        return cross(i, j, p) >= 0 and cross(j, k, p) >= 0 and cross(k, i, p) >= 0

    while len(idx) > 3:
        n = len(idx)
        for t in range(n):
            i, j, k = idx[t - 1], idx[t], idx[(t + 1) % n]
            if cross(i, j, k) > 1e-12 and not any(contains(i, j, k, p) for p in idx if p not in (i, j, k)):
                out.append((i, j, k))
                del idx[t]
                break
        else:  # no ear: a degenerate (collinear or self-touching) rest; fan it
            out += [(idx[0], idx[t], idx[t + 1]) for t in range(1, n - 1) if abs(cross(idx[0], idx[t], idx[t + 1])) > 0]
            return out
    if abs(cross(*idx)) > 0:
        out.append((idx[0], idx[1], idx[2]))
    return out


def extruded_polygons(paths: list[np.ndarray], height: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed mesh of SDF ``<polyline>`` paths (each (n, 2), in the geometry's frame) extruded from
    z = 0 to ``height``, as gz-common extrudes them: a path inside another is a hole in it, the others
    are polygons of their own. Vertices (n, 3) and faces (m, 3), faces outward."""
    rings = []
    for path in paths:
        ring = np.asarray(path, dtype=np.float64)
        if len(ring) > 1 and np.allclose(ring[0], ring[-1]):
            ring = ring[:-1]  # a closed path repeats its first point
        rings.append(ring)
    holes_of: dict[int, list[np.ndarray]] = {i: [] for i in range(len(rings))}
    holes = set()
    for i, ring in enumerate(rings):
        owner = next((j for j, other in enumerate(rings) if j != i and _inside(ring[0], other)), None)
        if owner is not None:
            holes_of[owner].append(ring if _signed_area(ring) < 0 else ring[::-1])
            holes.add(i)
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    for i, ring in enumerate(rings):
        if i in holes:
            continue
        outer = ring if _signed_area(ring) > 0 else ring[::-1]
        cap = _bridged(outer, holes_of[i])
        base = sum(len(v) for v in vertices)
        n = len(cap)
        vertices.append(np.column_stack([np.vstack([cap, cap]), np.repeat([0.0, height], n)]))
        tris = np.asarray(_ear_clip(cap), dtype=np.int64).reshape(-1, 3)
        faces += [base + tris[:, ::-1], base + n + tris]  # bottom facing down, top facing up
        # the side walls: one quad per edge of the outer ring and of each hole (bridges have none)
        for loop in [outer, *holes_of[i]]:
            start = sum(len(v) for v in vertices)
            m = len(loop)
            vertices.append(np.column_stack([np.vstack([loop, loop]), np.repeat([0.0, height], m)]))
            k = np.arange(m)
            nxt = (k + 1) % m
            faces += [
                np.column_stack([start + k, start + nxt, start + m + nxt]),
                np.column_stack([start + k, start + m + nxt, start + m + k]),
            ]
    # one vertex per position, so that the caps and the walls share their edges (the mesh is closed)
    merged, index = np.unique(np.round(np.vstack(vertices), MERGE_DECIMALS), axis=0, return_inverse=True)
    return merged, index.reshape(-1)[np.vstack(faces)]
