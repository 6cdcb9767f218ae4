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


def extruded_polygons(paths: list[np.ndarray], height: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed mesh of SDF ``<polyline>`` paths (each (n, 2), in the geometry's frame) extruded from
    z = 0 to ``height``, as gz-common extrudes them: a path inside another is a hole in it, the others
    are polygons of their own. Vertices (n, 3) and faces (m, 3), faces outward (Shapely for the
    polygons, trimesh with earcut for the triangulation)."""
    import shapely
    import trimesh

    rings = [shapely.Polygon(np.asarray(path, dtype=np.float64)) for path in paths]
    holes_of: dict[int, list[shapely.Polygon]] = {i: [] for i in range(len(rings))}
    holes = set()
    for i, ring in enumerate(rings):
        first = shapely.Point(ring.exterior.coords[0])
        owner = next((j for j, other in enumerate(rings) if j != i and other.contains(first)), None)
        if owner is not None:
            holes_of[owner].append(ring)
            holes.add(i)
    pieces = []
    for i, ring in enumerate(rings):
        if i not in holes:
            polygon = shapely.Polygon(ring.exterior.coords, [h.exterior.coords for h in holes_of[i]])
            pieces.append(
                trimesh.creation.extrude_polygon(shapely.geometry.polygon.orient(polygon), height, engine="earcut")
            )
    mesh: trimesh.Trimesh = trimesh.util.concatenate(pieces)  # type: ignore[assignment]
    mesh.merge_vertices(digits_vertex=MERGE_DECIMALS)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
