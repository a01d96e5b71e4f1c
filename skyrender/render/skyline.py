"""Rendered skylines: per-column binary search with ``scene.ray_test``.

For every image column u = i + 0.5 we search the v where rays stop seeing
sky and start hitting terrain (README, Conventions: NaN where the column sees only
sky, 0 where terrain reaches the top edge). Seen from above the ground, a
column's rays hit terrain below one boundary and miss above it, so a
bisection finds it with ~15 ray tests instead of H.

Modes: ``subpixel`` (continuous v, bisected until the error is at most ``tol`` px, default 0.05) and
integer (the top edge of the first row whose *centre* ray hits: exactly
what a one-sample-per-pixel full render gives).

Near clip (``near_m``): terrain nearer than that is ignored — what a
skyline looks like from anywhere within a few hundred metres (the far
horizon). Rays start ``near_m`` out; one that starts under the ground counts
as a hit (the terrain there rises above it), which keeps each column monotone.

Batched: one Dr.Jit kernel runs every column of every pose — thousands of
poses per call. Pose values enter as array buffers, never literals, so a new
pose does not recompile the kernel, and the kernel is frozen (``dr.freeze``)
so its Python tracing is paid once.
"""

from __future__ import annotations

import gc
import math
from types import SimpleNamespace

import numpy as np

from ..camera import Intrinsics, as_pose_array, pixel_ray_basis
from .terrain import GROUND_MARGIN_M, Terrain, surface_z

#: Threads per kernel launch (poses x columns); bounds memory for huge batches.
MAX_THREADS_PER_LAUNCH = 4_000_000


def skyline_iterations(height: int, subpixel: bool, tol: float) -> int:
    """Bisection steps to pin the boundary: to ``tol`` px, or to one row."""
    if subpixel:
        return max(1, math.ceil(math.log2(height / (2.0 * tol))))
    return max(1, math.ceil(math.log2(height + 1)))


def render_skylines(terrain: Terrain, poses, intrinsics: Intrinsics, *, subpixel: bool = True,
                    tol: float = 0.05, per_pose_intrinsics=None, with_distance: bool = False,
                    near_m: float = 0.0):
    """Skylines of many poses.

    Parameters
    ----------
    terrain : the Terrain scene (its curvature setting applies).
    poses : Pose or (P, 6) array (x, y, z, pan, tilt, swing); world metres and degrees.
    intrinsics : image size and default (f_px, cx, cy).
    subpixel : continuous boundary (error <= tol px) or integer rows.
    tol : sub-pixel tolerance in px.
    per_pose_intrinsics : optional (P, 3) array of (f_px, cx, cy) overriding the default.
    with_distance : also return how far away (m) each column's skyline terrain lies.
    near_m : ignore terrain nearer than this (m); 0 = none.

    Returns
    -------
    (P, W) float64 skylines, v coordinates (px); (W,) for a single pose. With
    ``with_distance``, also the (P, W) [or (W,)] distances in metres along the ray
    just below the boundary (inf where the column sees only sky).
    """
    pa = as_pose_array(poses)
    single = pa.ndim == 1
    pa = np.atleast_2d(pa)
    k = intrinsics.array() if per_pose_intrinsics is None else np.asarray(per_pose_intrinsics, np.float64)
    d0, du, dv = pixel_ray_basis(pa, k)
    origins, (d0, du, dv) = terrain.to_mesh_space(pa[:, :3], (d0, du, dv))
    W, H = intrinsics.width, intrinsics.height
    n_iter = skyline_iterations(H, subpixel, tol)
    per_launch = max(1, MAX_THREADS_PER_LAUNCH // W)
    out = np.empty((len(pa), W), dtype=np.float64)
    distance = np.empty((len(pa), W), dtype=np.float64) if with_distance else None
    kernel = _skyline_kernel if terrain.jit else _skyline_scalar
    for start in range(0, len(pa), per_launch):
        sl = slice(start, start + per_launch)
        basis = np.concatenate([origins[sl], d0[sl], du[sl], dv[sl]], axis=1)
        result = kernel(terrain, basis, W, H, subpixel, n_iter, with_distance, float(near_m))
        if with_distance:
            out[sl], distance[sl] = result
        else:
            out[sl] = result
    if with_distance:
        return (out[0], distance[0]) if single else (out, distance)
    return out[0] if single else out


def _skyline_kernel(terrain: Terrain, basis: np.ndarray, W: int, H: int, subpixel: bool, n_iter: int,
                    with_distance: bool = False, near_m: float = 0.0):
    """Run :func:`_bisect_columns` for every (pose, column) and return (P, W) float64
    skylines (and distances, with ``with_distance``)."""
    import drjit as dr

    mi = terrain.mi
    P = len(basis)
    # one frozen function per kernel shape, recorded once and then replayed: with one for all,
    # Dr.Jit 1.5 replayed a near-clipped call with the recording of another shape now and then
    # (wrong skylines, up to 50 deg off, after calls with and without the clip were mixed)
    static = (W, H, subpixel, n_iter, with_distance, near_m > 0)
    frozen = _frozen_bisect.get(static)
    if frozen is None:
        def bisect(scene, buf, idx, maxt, near, ground, grid):
            return _bisect_columns(scene, buf, idx, maxt, W, H, subpixel, n_iter, with_distance, near_m > 0, near,
                                   ground, grid)

        # one recording per terrain (its scene and buffers): Dr.Jit's default warns after 10, a bench-real run has more
        frozen = _frozen_bisect[static] = dr.freeze(bisect, warn_after=64)
    # no garbage collection while Dr.Jit records or replays the kernel: once (make test, 2026-12-03) the
    # process aborted in a collection started inside the recording (not reproduced since); collections wait
    collecting = gc.isenabled()
    gc.disable()
    try:
        result = frozen(terrain.scene, mi.Float(basis.astype(np.float32).ravel()), dr.arange(mi.UInt32, P * W),
                        dr.opaque(mi.Float, terrain.max_distance), dr.opaque(mi.Float, near_m), terrain.ground,
                        mi.Float(terrain.grid))
    finally:
        if collecting:
            gc.enable()
    if with_distance:
        return tuple(np.array(r, dtype=np.float64).reshape(P, W) for r in result)
    return np.array(result, dtype=np.float64).reshape(P, W)


_frozen_bisect: dict = {}


def _bisect_columns(scene, buf, idx, maxt, W: int, H: int, subpixel: bool, n_iter: int, with_distance: bool = False,
                    near_clip: bool = False, near=None, ground=None, grid=None):
    """One Dr.Jit kernel: thread = (pose, column); a symbolic loop bisects v; with
    ``with_distance`` one more ray, on the terrain side of the boundary, measures its distance;
    with ``near_clip`` rays start ``near`` metres out (and one starting under the ground hits:
    ``ground`` and ``grid`` are the mesh's vertex heights and grid, for
    :func:`~skyrender.render.terrain.surface_z`).

    ``buf`` holds 12 floats per pose (mesh-space origin and the ray basis d0, du, dv);
    ``idx`` enumerates pose * W + column. Frozen by ``dr.freeze``: the Python tracing of
    this function is paid once, later calls replay the recorded kernel.
    """
    import drjit as dr
    import mitsuba as mi

    n = dr.width(idx)
    pose = idx // W
    col = idx - pose * W

    def g(j):
        return dr.gather(mi.Float, buf, pose * 12 + j)

    o = mi.Point3f(g(0), g(1), g(2))
    du = mi.Vector3f(g(6), g(7), g(8))
    dv = mi.Vector3f(g(9), g(10), g(11))
    a = mi.Vector3f(g(3), g(4), g(5)) + (mi.Float(col) + 0.5) * du

    def ray(v):
        d = dr.normalize(a + v * dv)
        if near_clip:
            return mi.Ray3f(o + near * d, d, maxt, 0.0, [])
        return mi.Ray3f(o, d, maxt, 0.0, [])

    if near_clip:
        grid = [dr.gather(mi.Float, grid, k) for k in range(6)]
        ops = SimpleNamespace(floor=dr.floor, clip=dr.clip, select=dr.select, index=mi.UInt32,
                              gather=lambda z, index, active: dr.gather(mi.Float, z, index, active))

    def hits(v):
        r = ray(v)
        if near_clip:  # a start under the ground: the terrain there rises above the ray
            hit = scene.ray_test(r)
            height, inside = surface_z(r.o.x, r.o.y, grid, ground, ops, active=~hit)  # loads only where needed
            return hit | (inside & (r.o.z < height + GROUND_MARGIN_M))
        return scene.ray_test(r)

    def with_distance_of(v, v_terrain):
        if not with_distance:
            return v
        t = scene.ray_intersect_preliminary(ray(v_terrain)).t
        t = t + near if near_clip else t
        return v, dr.select(dr.isnan(v) | (t >= maxt), dr.inf, t)

    if subpixel:
        top, bottom = hits(mi.Float(0.0)), hits(mi.Float(float(H)))
        lo, hi = dr.zeros(mi.Float, n), dr.full(mi.Float, float(H), n)

        def body(lo, hi, i):
            mid = 0.5 * (lo + hi)
            hit = hits(mid)
            return dr.select(hit, lo, mid), dr.select(hit, mid, hi), i + 1

        lo, hi, _ = dr.while_loop((lo, hi, dr.zeros(mi.UInt32, n)), lambda lo, hi, i: i < n_iter, body)
        v = dr.select(top, 0.0, dr.select(bottom, 0.5 * (lo + hi), dr.nan))
        return with_distance_of(v, dr.select(top, 0.0, hi))
    lo, hi = dr.full(mi.Float, -1.0, n), dr.full(mi.Float, float(H), n)

    def body(lo, hi, i):
        mid = dr.floor(0.5 * (lo + hi))
        hit = hits(mid + 0.5)
        return dr.select(hit, lo, mid), dr.select(hit, mid, hi), i + 1

    lo, hi, _ = dr.while_loop((lo, hi, dr.zeros(mi.UInt32, n)), lambda lo, hi, i: (i < n_iter) & (hi - lo > 1.0), body)
    return with_distance_of(dr.select(hi >= float(H), dr.nan, hi), hi + 0.5)


def _skyline_scalar(terrain: Terrain, basis: np.ndarray, W: int, H: int, subpixel: bool, n_iter: int,
                    with_distance: bool = False, near_m: float = 0.0, ray_test=None):
    """The same bisection in numpy for the scalar fallback variant (slow). ``ray_test(o, d)``
    (mesh-space origins and unit directions -> bool hits) defaults to the terrain's own; the
    renderer benchmark passes another ray tracer's to time it on the same work."""
    ray_test = terrain.mesh_ray_test if ray_test is None else ray_test
    P = len(basis)
    o = np.repeat(basis[:, 0:3], W, axis=0)
    du = np.repeat(basis[:, 6:9], W, axis=0)
    dv = np.repeat(basis[:, 9:12], W, axis=0)
    a = np.repeat(basis[:, 3:6], W, axis=0) + (np.tile(np.arange(W), P) + 0.5)[:, None] * du

    def unit(v):
        d = a + np.asarray(v)[:, None] * dv
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def hits(v):
        d = unit(v)
        if near_m > 0:
            start = o + near_m * d
            return ray_test(start, d) | terrain.mesh_under_ground(start)
        return ray_test(o, d)

    def with_distance_of(v, v_terrain):
        if not with_distance:
            return v.reshape(P, W)
        d = unit(v_terrain)
        t, _ = terrain.mesh_intersect(o + near_m * d, d)
        return v.reshape(P, W), np.where(np.isnan(v), np.inf, t + near_m).reshape(P, W)

    n = P * W
    if subpixel:
        top, bottom = hits(np.zeros(n)), hits(np.full(n, float(H)))
        lo, hi = np.zeros(n), np.full(n, float(H))
        for _ in range(n_iter):
            mid = 0.5 * (lo + hi)
            hit = hits(mid)
            lo, hi = np.where(hit, lo, mid), np.where(hit, mid, hi)
        return with_distance_of(np.where(top, 0.0, np.where(bottom, 0.5 * (lo + hi), np.nan)), np.where(top, 0.0, hi))
    else:
        lo, hi = np.full(n, -1.0), np.full(n, float(H))
        for _ in range(n_iter):
            active = hi - lo > 1.0
            mid = np.floor(0.5 * (lo + hi))
            hit = hits(mid + 0.5)
            lo, hi = np.where(hit | ~active, lo, mid), np.where(hit & active, mid, hi)
        return with_distance_of(np.where(hi >= H, np.nan, hi), hi + 0.5)


def strided_intrinsics(intrinsics: Intrinsics, stride: int) -> tuple[Intrinsics, np.ndarray]:
    """Intrinsics of a ``stride`` times smaller image whose column k samples the full
    image's column ``stride*k + stride//2`` exactly; returns them and those columns.
    Its v coordinates scale back by ``v_full = cy + stride * (v - cy_small)``."""
    W, H = intrinsics.width, intrinsics.height
    cols = np.arange(stride // 2, W, stride)
    f = intrinsics.f_px / stride
    # column k's centre k + 0.5 must look along full column centre cols[0] + 0.5 + stride * k
    cx = 0.5 - (cols[0] + 0.5 - intrinsics.cx) / stride
    small = Intrinsics(len(cols), max(2, int(np.ceil(H / stride))), f, cx, intrinsics.cy / stride)
    return small, cols


def strided_skylines(terrain: Terrain, poses: np.ndarray, intrinsics: Intrinsics, stride: int,
                     tol_px: float, with_distance: bool = False):
    """Skylines (P, n) of poses (P, 6) on every ``stride``-th column
    (:func:`strided_intrinsics`), in full-image v (px) to within ``tol_px`` full-image
    px, and those columns (n,): a render ``stride`` times cheaper. With
    ``with_distance``, (skylines, distances in m, columns)."""
    small, cols = strided_intrinsics(intrinsics, stride)
    rendered = render_skylines(terrain, poses, small, tol=tol_px / stride, with_distance=with_distance)
    if with_distance:
        rendered, distance = rendered
        return intrinsics.cy + stride * (rendered - small.cy), distance, cols
    return intrinsics.cy + stride * (rendered - small.cy), cols
