"""The DEM surface as a Mitsuba 3 scene, and batched ray queries against it.

Vertices sit at cell centres in coordinates *local* to the DEM (x, y minus
the DEM centre) so float32 stays precise to millimetres; two triangles per
quad, split south-west to north-east (README, Conventions). The mesh is a
``trimesh.Trimesh`` (:func:`terrain_trimesh`, what ``skyrender mesh`` exports) handed
to Mitsuba in memory (``mi.Mesh`` + ``mi.traverse``), not through a PLY file.

Earth curvature without rebuilding the mesh per camera: the terrain a
camera at C sees is lowered by c |P - C|^2 (horizontal distance). Since
|P - C|^2 = |P|^2 - 2 P.C + |C|^2, the mesh is lowered once by c |P|^2 and
the remaining part, an affine shear z += 2c P.C - c|C|^2, is applied
inversely to the rays. Lines stay lines under a shear, so this is exact and
costs nothing per ray: see :meth:`Terrain.to_mesh_space`.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..backend import is_jit, mitsuba
from ..camera import curvature_coeff
from ..dem import DEM


def terrain_mesh_arrays(dem: DEM, origin_xy, c: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (rows*cols, 3) float32 in local coordinates, lowered by c |P|^2,
    and faces (2 (rows-1)(cols-1), 3) uint32 split along the SW-NE diagonal.

    Built in place in their final types: a 1-arc-second tile has 12 M vertices and 25 M
    faces, and float64 / int64 intermediates of the whole grid would weigh gigabytes."""
    rows, cols = dem.shape
    x = (dem.x_centres - origin_xy[0]).astype(np.float64)
    y = (dem.y_centres - origin_xy[1]).astype(np.float64)
    vertices = np.empty((rows * cols, 3), np.float32)
    vertices[:, 0] = np.tile(x, rows)
    vertices[:, 1] = np.repeat(y, cols)
    vertices[:, 2] = (dem.elevation - c * (x[None, :] ** 2 + y[:, None] ** 2)).ravel()
    index = np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols)
    nw, sw = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    n = len(nw)
    faces = np.empty((2 * n, 3), np.uint32)
    faces[:n, 0], faces[:n, 1], faces[:n, 2] = sw, sw + 1, nw + 1  # (sw, se, ne)
    faces[n:, 0], faces[n:, 1], faces[n:, 2] = sw, nw + 1, nw  # (sw, ne, nw)
    return vertices, faces


#: A point this close above the surface counts as under it (m): float32 rounding of the
#: surface height (millimetres) must not let a ray that starts on a slope it runs along
#: escape as sky — at the bottom row of a column that would turn the whole column to sky.
GROUND_MARGIN_M = 0.02


def surface_z(x, y, grid, z, ops, active=True):
    """Height z of the mesh surface (mesh space: local, lowered) above points (x, y), exactly as
    the two triangles of each quad interpolate it, and whether (x, y) lies over the mesh at all.

    ``grid`` = (x0, y0, dx, dy, cols, rows): the first vertex (north-west) and the spacing (m;
    rows run south); ``z`` the vertices' z in row order. ``ops`` supplies ``floor``, ``clip``,
    ``select``, ``gather(z, index, active)`` and ``index(a)`` (to integers), so the same formula
    serves numpy arrays and a Dr.Jit kernel (where ``active`` masks the loads). It answers "does
    a ray start under the ground" with four loads and a few multiplies instead of a second ray
    traced upwards: a fifth of the far horizons' time. Float32 rounding makes it uncertain
    within millimetres of the surface, hence :data:`GROUND_MARGIN_M`."""
    x0, y0, dx, dy, cols, rows = grid
    cf, rf = (x - x0) / dx, (y0 - y) / dy
    inside = (cf >= 0.0) & (cf <= cols - 1.0) & (rf >= 0.0) & (rf <= rows - 1.0)
    c = ops.clip(ops.floor(cf), 0.0, cols - 2.0)
    r = ops.clip(ops.floor(rf), 0.0, rows - 2.0)
    u, s = cf - c, 1.0 - (rf - r)  # east and north fractions within the quad
    stride = ops.index(cols)
    nw = ops.index(r) * stride + ops.index(c)  # integer: a 2 x 2 mosaic of 1-arc-second tiles passes 2**24
    z_nw, z_ne = ops.gather(z, nw, active), ops.gather(z, nw + 1, active)
    z_sw, z_se = ops.gather(z, nw + stride, active), ops.gather(z, nw + stride + 1, active)
    below_diagonal = s <= u  # triangle (sw, se, ne); else (sw, ne, nw)
    height = ops.select(below_diagonal, z_sw + u * (z_se - z_sw) + s * (z_ne - z_se),
                        z_sw + s * (z_nw - z_sw) + u * (z_ne - z_nw))
    return height, inside


#: :func:`surface_z`'s operations on numpy arrays (the Dr.Jit kernel passes its own).
NumpyOps = SimpleNamespace(floor=np.floor, clip=np.clip, select=np.where, gather=lambda z, index, active=True: z[index],
                           index=lambda a: np.asarray(a).astype(np.int64))


def terrain_trimesh(dem: DEM, *, world: bool = False, curvature: bool = False):
    """The DEM's terrain as a ``trimesh.Trimesh`` (metres; x east, y north, z up): the mesh
    of :func:`terrain_mesh_arrays`, local to the DEM centre (or in world coordinates), lowered
    by earth curvature and refraction seen from the DEM centre when ``curvature``. The
    renderer hands exactly this mesh to Mitsuba; ``skyrender mesh`` writes it to a file."""
    import trimesh

    origin = np.array(dem.centre, np.float64)
    vertices, faces = terrain_mesh_arrays(dem, origin, curvature_coeff(curvature))
    vertices = vertices.astype(np.float64)
    if world:
        vertices[:, :2] += origin
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False)
    mesh.metadata.update({"dem": dem.name, "crs": dem.crs, "origin_xy": [0.0, 0.0] if world else origin.tolist()})
    return mesh


def mitsuba_scene(mi, vertices: np.ndarray, faces: np.ndarray):
    """A Mitsuba scene of one mesh built in memory (``mi.Mesh`` + ``mi.traverse``) from
    (V, 3) float32 vertices and (F, 3) uint32 faces."""
    mesh = mi.Mesh("terrain", len(vertices), len(faces), has_vertex_normals=False, has_vertex_texcoords=False)
    params = mi.traverse(mesh)
    params["vertex_positions"] = type(params["vertex_positions"])(vertices.ravel())
    params["faces"] = type(params["faces"])(faces.ravel())
    params.update()
    return mi.load_dict({"type": "scene", "terrain": mesh})


class Terrain:
    """A DEM as a Mitsuba scene, with ray queries in world coordinates.

    Parameters
    ----------
    dem : the DEM.
    curvature : apply earth curvature and refraction (README, Conventions); False = flat earth.
    variant : Mitsuba variant (default: ``SKYRENDER_VARIANT`` or ``llvm_ad_rgb``).
    """

    def __init__(self, dem: DEM, *, curvature: bool = True, variant: str | None = None):
        self.dem = dem
        self.curvature = curvature
        self.c = curvature_coeff(curvature)
        self.mi = mitsuba(variant)
        self.variant = self.mi.variant()
        self.jit = is_jit(self.variant)
        cx, cy = dem.centre
        self.origin = np.array([cx, cy, 0.0])
        vertices, faces = terrain_mesh_arrays(dem, self.origin[:2], self.c)
        self.faces = faces
        self.vertices = vertices
        self.scene = mitsuba_scene(self.mi, vertices, faces)
        xmin, xmax, ymin, ymax = dem.extent
        span = float(np.hypot(xmax - xmin, ymax - ymin))
        #: No ray needs to go further than this (metres): replaces the 10 km far clip.
        self.max_distance = 2.0 * span + 10_000.0
        dx, dy = dem.cell_size
        #: (x0, y0, dx, dy, cols, rows) of the mesh's vertex grid (local metres), for :func:`surface_z`.
        self.grid = (float(vertices[0, 0]), float(vertices[0, 1]), dx, dy, dem.shape[1], dem.shape[0])

    @property
    def ground(self):
        """The vertices' z as a Dr.Jit array (made once): :func:`surface_z` inside kernels."""
        if not hasattr(self, "_ground"):
            self._ground = self.mi.Float(self.vertices[:, 2].copy())
        return self._ground

    def mesh_under_ground(self, points) -> np.ndarray:
        """Do mesh-space points (N, 3) lie below the terrain surface, or less than
        :data:`GROUND_MARGIN_M` above it (over the mesh)?"""
        height, inside = surface_z(points[:, 0], points[:, 1], self.grid, self.vertices[:, 2], NumpyOps)
        return inside & (points[:, 2] < height + GROUND_MARGIN_M)

    @property
    def mesh(self):
        """The terrain as a ``trimesh.Trimesh`` (local to the DEM centre, curvature applied as
        configured): :func:`terrain_trimesh`, made on demand (it holds float64 copies)."""
        return terrain_trimesh(self.dem, curvature=self.curvature)

    @property
    def face_normals(self) -> np.ndarray:
        """(F, 3) unit upward normals of the (unlowered) terrain triangles."""
        if not hasattr(self, "_face_normals"):
            v = self.vertices.astype(np.float64)
            v[:, 2] += self.c * (v[:, 0] ** 2 + v[:, 1] ** 2)  # undo the mesh lowering
            a, b, c = v[self.faces[:, 0]], v[self.faces[:, 1]], v[self.faces[:, 2]]
            n = np.cross(b - a, c - a)
            self._face_normals = n / np.linalg.norm(n, axis=1, keepdims=True)
        return self._face_normals

    # --- coordinate frames ---------------------------------------------------------
    def to_mesh_space(self, origins, vectors=(), viewer_xy=None):
        """Map world points and direction vectors into the mesh's local, sheared frame.

        ``origins`` (..., 3) world points; ``vectors`` a tuple of (..., 3) directions;
        ``viewer_xy`` (..., 2) the camera whose curvature applies (default: the origins).
        Returns (origins', [vectors']) as float64 arrays; ray parameters t are unchanged.
        """
        o = np.asarray(origins, dtype=np.float64) - self.origin
        v_xy = o[..., :2] if viewer_xy is None else np.asarray(viewer_xy, dtype=np.float64) - self.origin[:2]
        c = self.c
        vx, vy = v_xy[..., 0], v_xy[..., 1]  # components, not sums over a short axis: 2x faster on many rays
        o[..., 2] += c * (vx * vx + vy * vy) - 2 * c * (o[..., 0] * vx + o[..., 1] * vy)
        out = []
        for vec in vectors:
            vec = np.array(vec, dtype=np.float64)
            vec[..., 2] -= 2 * c * (vec[..., 0] * vx + vec[..., 1] * vy)
            out.append(vec)
        return o, out

    def _rays(self, origins, directions, maxt=None):
        mi = self.mi
        o = np.asarray(origins, dtype=np.float32)
        d = np.asarray(directions, dtype=np.float32)
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(o[:, k]) for k in range(3))),
                       mi.Vector3f(*(mi.Float(d[:, k]) for k in range(3))))
        ray.maxt = mi.Float(np.full(len(o), self.max_distance, np.float32) if maxt is None
                            else np.asarray(maxt, np.float32))
        return ray

    # --- queries -------------------------------------------------------------------
    def ray_test(self, origins, directions, maxt=None, viewer_xy=None) -> np.ndarray:
        """Does the ray hit the terrain within ``maxt`` metres (default: anywhere)?

        Arrays: origins, directions (N, 3) in world coordinates (directions need not be
        unit: ``maxt`` is in units of the direction's length); viewer_xy (N, 2) whose
        curvature applies (default: the origins). Returns bool (N,).
        """
        o, (d,) = self.to_mesh_space(origins, (directions,), viewer_xy)
        return self.mesh_ray_test(o, d, maxt)

    def mesh_ray_test(self, o, d, maxt=None) -> np.ndarray:
        """:meth:`ray_test` for rays already in mesh space (see :meth:`to_mesh_space`)."""
        if len(o) == 0:  # Dr.Jit aborts the process on empty rays
            return np.zeros(0, dtype=bool)
        norm = np.linalg.norm(d, axis=-1)
        d = d / norm[:, None]
        if maxt is not None:
            maxt = np.asarray(maxt, np.float64) * norm
        if not self.jit:
            return self._scalar_loop(o, d, maxt, "ray_test")
        return np.array(self.scene.ray_test(self._rays(o, d, maxt)), dtype=bool)

    def mesh_intersect(self, o, d) -> tuple[np.ndarray, np.ndarray]:
        """First hit of rays already in mesh space (see :meth:`to_mesh_space`): t (N,) in
        units of the direction's length (inf where the ray misses) and the hit face's unit
        upward normal (N, 3) (world; meaningless where t is inf)."""
        norm = np.linalg.norm(d, axis=-1)
        d = d / norm[:, None]
        if self.jit:
            pi = self.scene.ray_intersect_preliminary(self._rays(o, d))
            t = np.array(pi.t, dtype=np.float64)
            face = np.array(pi.prim_index, dtype=np.int64)
            n = self.face_normals[np.clip(face, 0, len(self.face_normals) - 1)]
        else:
            t, n = self._scalar_loop(o, d, None, "ray_intersect")
        hit = np.isfinite(t) & (t < self.max_distance)
        return np.where(hit, t, np.inf) / norm, n

    def intersect(self, origins, directions, viewer_xy=None):
        """First hit of each ray with the terrain.

        Returns (t, points, normals): t (N,) distance in units of the direction's length
        (inf where the ray misses); points (N, 3) the hit in world coordinates (as the
        terrain really is, not lowered); normals (N, 3) unit geometric normals (world).
        """
        if len(origins) == 0:  # Dr.Jit aborts the process on empty rays
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3))
        o, (d,) = self.to_mesh_space(origins, (directions,), viewer_xy)
        t, n = self.mesh_intersect(o, d)
        hit = np.isfinite(t)
        dirs = np.asarray(directions, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            seen = np.asarray(origins, dtype=np.float64) + t[:, None] * dirs
        viewer = np.asarray(origins, dtype=np.float64)[:, :2] if viewer_xy is None else np.asarray(viewer_xy)
        if self.c:
            seen[hit, 2] += self.c * np.sum((seen[hit, :2] - viewer[hit]) ** 2, axis=-1)
        n = np.where(hit[:, None], n, np.nan)
        return t, seen, n

    def _scalar_loop(self, o, d, maxt, what):
        """Per-ray fallback for the scalar variant (slow, but it runs)."""
        mi = self.mi
        hits, ts, ns = [], [], []
        for i in range(len(o)):
            ray = mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i]))
            ray.maxt = float(self.max_distance if maxt is None else maxt[i])
            if what == "ray_test":
                hits.append(bool(self.scene.ray_test(ray)))
            else:
                si = self.scene.ray_intersect(ray)
                ts.append(float(si.t))
                ns.append([si.n.x, si.n.y, si.n.z])
        if what == "ray_test":
            return np.array(hits, dtype=bool)
        return np.array(ts, dtype=np.float64), np.array(ns, dtype=np.float64).reshape(-1, 3)
