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

Two passes (sub-pixel mode, an option: :data:`COARSE_COLUMNS`): every 4th column is bisected from the whole column,
then each other column starts between its neighbours' boundaries and steps out until it brackets its own
(:func:`_bisect_from`), ending on the same grid interval: the same skyline to the bit wherever a column is
monotone as above, in 0.7-0.8x the time (``experiments/render/two-pass/``).

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
                    near_m: float = 0.0, guess: np.ndarray | None = None):
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
    guess : optional (P, W) v (px) near where each column's boundary is expected (NaN: no guess), e.g.
        from the neighbouring columns: the bisection then starts there (:func:`_bisect_columns`) and
        ends in the same place with fewer rays; the same values to the bit where a column's rays hit
        terrain below one boundary and miss above it (always for a level camera; sub-pixel mode only).

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
    out = np.empty((len(pa), W), dtype=np.float64)
    distance = np.empty((len(pa), W), dtype=np.float64) if with_distance else None
    basis = np.concatenate([origins, d0, du, dv], axis=1)
    exact = terrain.jit and subpixel and guess_is_exact(H, n_iter)
    if guess is not None and exact:
        passes = [(np.arange(W), np.asarray(guess, np.float64).reshape(len(pa), W))]
    elif guess is None and exact and COARSE_COLUMNS and W >= 2 * COARSE_COLUMNS:
        # every COARSE_COLUMNS-th column (and the last) first; the others then start between their neighbours
        first = np.unique(np.r_[np.arange(0, W, COARSE_COLUMNS), W - 1])
        passes = [(first, None), (np.setdiff1d(np.arange(W), first), "between")]
    else:
        passes = [(np.arange(W), None)]
    for cols, start in passes:
        if isinstance(start, str):  # linear between the first pass's columns on either side
            right = np.searchsorted(first, cols)
            w = (cols - first[right - 1]) / (first[right] - first[right - 1])
            start = out[:, first[right - 1]] * (1 - w) + out[:, first[right]] * w
        elif start is not None:
            start = start[:, cols]
        per_launch = max(1, MAX_THREADS_PER_LAUNCH // len(cols))
        for lo in range(0, len(pa), per_launch):
            sl = slice(lo, lo + per_launch)
            if terrain.jit:
                result = _skyline_kernel(terrain, basis[sl], W, H, subpixel, n_iter, with_distance, float(near_m),
                                         None if start is None else start[sl], cols)
            else:
                result = _skyline_scalar(terrain, basis[sl], W, H, subpixel, n_iter, with_distance, float(near_m))
            if with_distance:
                out[sl, cols], distance[sl, cols] = result
            else:
                out[sl, cols] = result
    if with_distance:
        return (out[0], distance[0]) if single else (out, distance)
    return out[0] if single else out


#: With this set (an int, e.g. 4), sub-pixel renders first bisect every COARSE_COLUMNS-th column from the whole
#: column, then start each other column between its two neighbours' boundaries (:func:`_bisect_from`): the same
#: skylines to the bit where columns are monotone, in 0.68-0.80x the time. Off (None) until measured on the real-
#: photo benchmark: on tilted, rolled cameras 1 column in 500,000 came out otherwise (experiments/render/two-pass/).
COARSE_COLUMNS = None


def guess_is_exact(H: int, n_iter: int) -> bool:
    """Whether a bisection started from a guess ends on the very float32 values of one started from the whole
    column: every point the bisection visits (multiples of H / 2**n_iter, and the final midpoint) is exact in
    float32 when 2 * 2**n_iter * H <= 2**24."""
    return 2 * (2 ** n_iter) * H <= 2 ** 24


def _skyline_kernel(terrain: Terrain, basis: np.ndarray, W: int, H: int, subpixel: bool, n_iter: int,
                    with_distance: bool = False, near_m: float = 0.0, guess: np.ndarray | None = None,
                    cols: np.ndarray | None = None):
    """Run :func:`_bisect_columns` for every (pose, column of ``cols``, default all W) and return (P, n)
    float64 skylines (and distances, with ``with_distance``); ``guess`` (P, n) v or NaN: where each column
    starts."""
    import drjit as dr

    mi = terrain.mi
    P = len(basis)
    n_cols = W if cols is None else len(cols)  # a subset of the columns is gathered per thread; all of them are not
    # one frozen function per kernel shape, recorded once and then replayed: with one for all,
    # Dr.Jit 1.5 replayed a near-clipped call with the recording of another shape now and then
    # (wrong skylines, up to 50 deg off, after calls with and without the clip were mixed)
    static = (W, H, subpixel, n_iter, with_distance, near_m > 0, guess is not None, n_cols)
    frozen = _frozen_bisect.get(static)
    if frozen is None:
        def bisect(scene, buf, idx, maxt, near, ground, grid, start, columns):
            return _bisect_columns(scene, buf, idx, maxt, W, H, subpixel, n_iter, with_distance, near_m > 0, near,
                                   ground, grid, start, columns, n_cols)

        # one recording per terrain (its scene and buffers): Dr.Jit's default warns after 10, a bench-real run has more
        frozen = _frozen_bisect[static] = dr.freeze(bisect, warn_after=64)
    # no garbage collection while Dr.Jit records or replays the kernel: once (make test, 2026-12-03) the
    # process aborted in a collection started inside the recording (not reproduced since); collections wait
    collecting = gc.isenabled()
    gc.disable()
    try:
        start = None if guess is None else mi.Float(guess.astype(np.float32).ravel())
        result = frozen(terrain.scene, mi.Float(basis.astype(np.float32).ravel()), dr.arange(mi.UInt32, P * n_cols),
                        dr.opaque(mi.Float, terrain.max_distance), dr.opaque(mi.Float, near_m), terrain.ground,
                        mi.Float(terrain.grid), start,
                        None if n_cols == W else mi.UInt32(np.asarray(cols).astype(np.uint32)))
    finally:
        if collecting:
            gc.enable()
    if with_distance:
        return tuple(np.array(r, dtype=np.float64).reshape(P, n_cols) for r in result)
    return np.array(result, dtype=np.float64).reshape(P, n_cols)


_frozen_bisect: dict = {}


def _bisect_columns(scene, buf, idx, maxt, W: int, H: int, subpixel: bool, n_iter: int, with_distance: bool = False,
                    near_clip: bool = False, near=None, ground=None, grid=None, start=None, columns=None,
                    n_cols: int | None = None):
    """One Dr.Jit kernel: thread = (pose, column); a symbolic loop bisects v; with
    ``with_distance`` one more ray, on the terrain side of the boundary, measures its distance;
    with ``near_clip`` rays start ``near`` metres out (and one starting under the ground hits:
    ``ground`` and ``grid`` are the mesh's vertex heights and grid, for
    :func:`~skyrender.render.terrain.surface_z`).

    ``buf`` holds 12 floats per pose (mesh-space origin and the ray basis d0, du, dv);
    ``idx`` enumerates pose * n_cols + k, thread k of a pose rendering column ``columns[k]`` (all W
    columns when None); ``start`` (sub-pixel mode), one v per thread or NaN: where
    :func:`_bisect_from` starts instead of the whole column. Frozen by ``dr.freeze``: the Python tracing of
    this function is paid once, later calls replay the recorded kernel.
    """
    import drjit as dr
    import mitsuba as mi

    n = dr.width(idx)
    if columns is None:
        pose = idx // W
        col = idx - pose * W
    else:
        pose = idx // n_cols
        col = dr.gather(mi.UInt32, columns, idx - pose * n_cols)

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

    if subpixel and start is not None:
        v, v_terrain = _bisect_from(hits, dr.gather(mi.Float, start, idx), n, H, n_iter)
        return with_distance_of(v, v_terrain)
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


def _bisect_from(hits, start, n: int, H: int, n_iter: int):
    """The sub-pixel bisection of :func:`_bisect_columns` started near ``start`` (v, px; NaN: no guess): the
    same (v, v of the terrain side) to the bit, in fewer rays where the guess is close.

    The whole-column bisection tests v = 0 and v = H, then halves [0, H] ``n_iter`` times: it ends on the
    interval of the grid of step H / 2**n_iter (the *units*) that holds the boundary. Any bracket on that grid,
    its top end seeing sky and its bottom end terrain, halved (at whole units) down to one unit, ends on the
    same interval, so this tests the unit nearest the guess, then steps away from it by 1, 2, 4, ... units
    until the boundary is bracketed (or the frame's edge is reached: terrain at the top, v = 0, or sky at the
    bottom, NaN), then halves. Without a guess it tests 0, then H, then halves [0, H]: the same rays as the
    whole-column bisection. Integer units keep every point exact (:func:`guess_is_exact`)."""
    import drjit as dr
    import mitsuba as mi

    N = 2 ** n_iter
    unit = float(H) / N
    guessed = dr.isfinite(start)
    g = mi.Int32(dr.clip(dr.round(dr.select(guessed, start, 0.0) / unit), 0.0, float(N)))
    # phases: 0 probe the guess, 1 step up the column (towards v = 0), 2 step down, 3 halve, 4 top, 5 bottom,
    # 6 done; a lane without a guess starts at 4 (is there terrain at v = 0?) then 5 (sky at v = H?)
    PROBE, UP, DOWN, HALVE, TOP, BOTTOM, DONE = (mi.UInt32(k) for k in range(7))
    phase = dr.select(guessed, PROBE, TOP)
    lo, hi, step = dr.zeros(mi.Int32, n), dr.full(mi.Int32, N, n), dr.full(mi.Int32, 1, n)
    at_top, no_terrain = dr.zeros(mi.Bool, n), dr.zeros(mi.Bool, n)

    def body(phase, lo, hi, step, at_top, no_terrain):
        point = dr.select(phase == PROBE, g,
                          dr.select(phase == UP, dr.maximum(hi - step, 0),
                                    dr.select(phase == DOWN, dr.minimum(lo + step, N),
                                              dr.select(phase == HALVE, (lo + hi) >> 1,
                                                        dr.select(phase == TOP, mi.Int32(0), mi.Int32(N))))))
        hit = hits(mi.Float(point) * unit)
        # the probe: terrain there puts the boundary above it (hi), sky below it (lo); at the frame's edge, done
        probe, up, down, halve = phase == PROBE, phase == UP, phase == DOWN, phase == HALVE
        top, bottom = phase == TOP, phase == BOTTOM
        new_hi = dr.select((probe | up | halve) & hit, point, hi)
        new_lo = dr.select((probe | down | halve) & ~hit, point, lo)
        new_lo = dr.select(up & ~hit, point, new_lo)  # sky at the step: the bracket's top end
        new_hi = dr.select(down & hit, point, new_hi)
        new_lo = dr.select(bottom & hit, mi.Int32(0), new_lo)
        new_hi = dr.select(bottom & hit, mi.Int32(N), new_hi)
        terrain_at_top = hit & (point == 0) & (probe | up | top)
        sky_at_bottom = ~hit & (point == N) & (probe | down | bottom)
        bracketed = ((up & ~hit) | (down & hit) | (bottom & hit) | halve) & (new_hi - new_lo > 1)
        next_phase = dr.select(probe, dr.select(hit, UP, DOWN), phase)
        next_phase = dr.select(top & ~hit, BOTTOM, next_phase)
        next_phase = dr.select(bracketed, HALVE, next_phase)
        next_phase = dr.select(((up & ~hit) | (down & hit) | halve | (bottom & hit)) & (new_hi - new_lo <= 1), DONE,
                               next_phase)
        next_phase = dr.select(terrain_at_top | sky_at_bottom, DONE, next_phase)
        next_step = dr.select((up & hit) | (down & ~hit), step * 2, step)
        return (next_phase, new_lo, new_hi, next_step, at_top | terrain_at_top, no_terrain | sky_at_bottom)

    phase, lo, hi, step, at_top, no_terrain = dr.while_loop(
        (phase, lo, hi, step, at_top, no_terrain), lambda phase, *_: phase != DONE, body)
    lo_v, hi_v = mi.Float(lo) * unit, mi.Float(hi) * unit
    v = dr.select(at_top, 0.0, dr.select(no_terrain, dr.nan, 0.5 * (lo_v + hi_v)))
    return v, dr.select(at_top, 0.0, dr.select(no_terrain, float(H), hi_v))


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
