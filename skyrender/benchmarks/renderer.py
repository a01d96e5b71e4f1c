"""Renderer benchmark: skyline cost against full renders, in one run.

``python -m skyrender.benchmarks.renderer [--size 600] [--width 640] [--height 480] [--poses 1000]``

On a fractal 600 x 600 DEM at 50 m it prints: scene build time; skyline ms
per pose (single pose, sub-pixel and integer; batched); a full-image Mitsuba
ray cast (one primary ray per pixel) and a realistic photo; and the peer
baseline: the same skyline from a full-image embreex ray cast through trimesh
(``pip install skyrender[dev]``). Ratios are taken against the single-pose
sub-pixel skyline. Writes the figures to ``experiments/render/bench-render.json``.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from ..evaluate import REPO
from . import median_seconds, write_figures


def _best_ms(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs, in ms (after one warm-up)."""
    return 1000.0 * median_seconds(fn, repeats)


def benchmark_view(dem):
    """A camera in a low place 9 km from the DEM centre, looking at its mountains."""
    cx, cy = dem.centre
    x, y = cx - 6000.0, cy - 9000.0
    pan = float(np.degrees(np.arctan2(cx - x, cy - y)))
    return x, y, pan


def mitsuba_full_render(terrain, pose, intrinsics, spp: int = 1):
    """A plain full Mitsuba render of the view: ``mi.render`` with a depth integrator
    and a perspective sensor at the pose (flat earth; a timing baseline). Returns a
    function that renders once and evaluates the image."""
    import drjit as dr

    from ..camera import mitsuba_to_world

    mi = terrain.mi
    sensor = mi.load_dict({
        "type": "perspective", "fov": intrinsics.fov, "fov_axis": "x", "far_clip": terrain.max_distance,
        "to_world": mi.ScalarTransform4f(mitsuba_to_world(pose, terrain.origin).tolist()),
        "film": {"type": "hdrfilm", "width": intrinsics.width, "height": intrinsics.height,
                 "rfilter": {"type": "box"}, "pixel_format": "luminance"},
        "sampler": {"type": "independent", "sample_count": spp},
    })
    integrator = mi.load_dict({"type": "depth"})

    def run():
        image = mi.render(terrain.scene, sensor=sensor, integrator=integrator, spp=spp)
        dr.eval(image)
        return image

    return run


def embree_caster(terrain):
    """trimesh + embreex ray caster over the Terrain's own mesh (mesh space: identical
    geometry), its BVH built; or (None, reason) when embreex is unavailable."""
    try:
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector
    except Exception as exc:  # optional dev dependency
        return None, f"trimesh/embreex unavailable ({exc})"
    caster = RayMeshIntersector(trimesh.Trimesh(terrain.vertices.astype(np.float64), terrain.faces, process=False))
    caster.intersects_any(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]))  # build the BVH outside the timing
    return caster, ""


def embree_full_image_skyline(caster, terrain, pose, intrinsics):
    """Peer baseline 1: an embreex full-image ray cast (one ray per pixel centre), the
    first terrain row per column (what a one-sample full render gives)."""
    from ..camera import pixel_ray_basis
    from ..features.skyline import skyline_of_terrain

    W, H = intrinsics.width, intrinsics.height
    u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    d0, du, dv = pixel_ray_basis(pose, intrinsics.array())
    dirs = d0[0] + u[..., None] * du[0] + v[..., None] * dv[0]
    o, (dirs,) = terrain.to_mesh_space(pose.array()[:3], (dirs.reshape(-1, 3),))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    hit = caster.intersects_any(np.broadcast_to(o, dirs.shape), dirs).reshape(H, W)
    return skyline_of_terrain(hit)


def embree_bisected_skyline(caster, terrain, pose, intrinsics, tol: float = 0.05):
    """Peer baseline 2, the same work as ours: the per-column bisection of
    :func:`skyrender.render.skyline.render_skylines` (sub-pixel, ``tol`` px, the same
    number of ray tests per column), each step's rays traced by embreex."""
    from ..camera import pixel_ray_basis
    from ..render.skyline import _skyline_scalar, skyline_iterations

    pa = np.atleast_2d(pose.array())
    d0, du, dv = pixel_ray_basis(pa, intrinsics.array())
    origins, (d0, du, dv) = terrain.to_mesh_space(pa[:, :3], (d0, du, dv))
    basis = np.concatenate([origins, d0, du, dv], axis=1)
    W, H = intrinsics.width, intrinsics.height
    return _skyline_scalar(terrain, basis, W, H, True, skyline_iterations(H, True, tol),
                           ray_test=lambda o, d: caster.intersects_any(o, d))[0]


def scene_from_arrays(terrain) -> object:
    """Baseline for the scene build: the same mesh arrays straight into ``mi.Mesh`` (no trimesh)."""
    from ..render.terrain import mitsuba_scene, terrain_mesh_arrays

    return mitsuba_scene(terrain.mi, *terrain_mesh_arrays(terrain.dem, terrain.origin[:2], terrain.c))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=600, help="DEM cells per side (50 m cells)")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--poses", type=int, default=1000, help="poses in the batched run")
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "render", "bench-render.json"))
    args = parser.parse_args(argv)

    from ..backend import active_variant
    from ..camera import Intrinsics, Pose
    from ..dem import fractal_terrain
    from ..render import Terrain, render_skylines
    from ..render.photo import Look, cast_pixel_rays, render_photo

    dem = fractal_terrain(args.size, 50.0, seed=0)
    terrain = Terrain(dem)  # warm-up: the first build pays for Mitsuba's start
    build_s = _best_ms(lambda: Terrain(dem), 5) / 1000.0
    arrays_s = _best_ms(lambda: scene_from_arrays(terrain), 5) / 1000.0
    K = Intrinsics.from_fov(60.0, args.width, args.height)
    x, y, pan = benchmark_view(dem)
    pose = dem.camera_pose(x, y, 2.0, pan, 2.0, 0.0)
    rng = np.random.default_rng(0)
    pans = iter(pan + rng.uniform(-30, 30, 100_000))

    def new_pose():  # a different pose every call: proves no per-pose recompilation
        return Pose(pose.x, pose.y, pose.z, next(pans), pose.tilt, pose.swing)

    single_sub = _best_ms(lambda: render_skylines(terrain, new_pose(), K, subpixel=True), args.repeats)
    single_int = _best_ms(lambda: render_skylines(terrain, new_pose(), K, subpixel=False), args.repeats)
    batch = np.tile(pose.array(), (args.poses, 1))
    batch[:, 3] += rng.uniform(-30, 30, args.poses)
    batch[:, 0:2] += rng.uniform(-200, 200, (args.poses, 2))
    batch[:, 2] = dem.ground(batch[:, 0], batch[:, 1]) + 2.0
    batched_ms = _best_ms(lambda: render_skylines(terrain, batch, K), 3) / args.poses
    full_ms = _best_ms(mitsuba_full_render(terrain, pose, K), 5)
    cast_ms = _best_ms(lambda: cast_pixel_rays(terrain, pose, K, 1), 5)
    photo_ms = _best_ms(lambda: render_photo(terrain, pose, K, Look(supersample=1)), 3)

    sky_int = render_skylines(terrain, pose, K, subpixel=False)
    sky_sub = render_skylines(terrain, pose, K, subpixel=True)
    caster, why = embree_caster(terrain)
    if caster is not None:  # timed as ours: median of --repeats after a warm-up
        embree_sky = embree_full_image_skyline(caster, terrain, pose, K)
        embree = _best_ms(lambda: embree_full_image_skyline(caster, terrain, new_pose(), K), max(3, args.repeats // 6))
        embree_bis_sky = embree_bisected_skyline(caster, terrain, pose, K)
        embree_bis = _best_ms(lambda: embree_bisected_skyline(caster, terrain, new_pose(), K), args.repeats)

    print(f"skyrender renderer benchmark — Mitsuba variant {active_variant()}")
    print(f"DEM: fractal {args.size} x {args.size} cells of 50 m; image {args.width} x {args.height}")
    print(f"scene build (trimesh -> mi.Mesh + mi.traverse, {2 * (args.size - 1) ** 2:,} triangles): {build_s:.3f} s; "
          f"from the arrays without trimesh (baseline): {arrays_s:.3f} s; ratio {build_s / arrays_s:.2f}")
    print(f"skyline, single pose, sub-pixel (<= 0.05 px): {single_sub:8.3f} ms/pose")
    print(f"skyline, single pose, integer rows:           {single_int:8.3f} ms/pose")
    print(f"skyline, batched {args.poses} poses, sub-pixel:      {batched_ms:8.3f} ms/pose")
    print(f"full Mitsuba render (mi.render, depth, 1 spp): {full_ms:7.3f} ms")
    print(f"full-image ray cast with hit points/normals:  {cast_ms:8.3f} ms")
    print(f"realistic photo render (shaded, shadows):     {photo_ms:8.3f} ms")
    if caster is None:
        print(f"embreex baselines: skipped — {why}")
    else:
        agree = np.mean((embree_sky == sky_int) | (np.isnan(embree_sky) & np.isnan(sky_int)))
        print(f"embreex full-image skyline (trimesh):         {embree:8.3f} ms "
              f"(agrees with our integer skyline on {100 * agree:.1f} % of columns)")
        close = np.nanmax(np.abs(embree_bis_sky - sky_sub))
        print(f"embreex per-column bisection (same work):     {embree_bis:8.3f} ms "
              f"(largest difference from ours {close:.3f} px)")
    print("ratios (higher = skyline faster):")
    print(f"  full Mitsuba render / skyline single: {full_ms / single_sub:7.1f}x   "
          f"/ skyline batched: {full_ms / batched_ms:7.1f}x   (target >= 20x)")
    if caster is not None:
        print(f"  embreex full image / skyline single:  {embree / single_sub:7.1f}x   "
              f"/ skyline batched: {embree / batched_ms:7.1f}x   (target >= 100x)")
        print(f"  embreex bisection / skyline single:   {embree_bis / single_sub:7.1f}x   "
              f"/ skyline batched: {embree_bis / batched_ms:7.1f}x   (the peer doing the same work)")
    print(f"  target skyline <= 0.5 ms/pose: single {'met' if single_sub <= 0.5 else 'NOT met'}, "
          f"batched {'met' if batched_ms <= 0.5 else 'NOT met'}")
    figures = {"scene_build_s": build_s, "scene_from_arrays_s": arrays_s, "skyline_single_subpixel_ms": single_sub,
               "skyline_single_integer_ms": single_int, "skyline_batched_ms_per_pose": batched_ms,
               "mitsuba_full_render_ms": full_ms, "pixel_ray_cast_ms": cast_ms, "photo_render_ms": photo_ms,
               "ratio_full_render_to_single": full_ms / single_sub, "ratio_full_render_to_batched": full_ms / batched_ms}
    if caster is not None:
        figures.update(embree_full_image_ms=embree, embree_bisection_ms=embree_bis,
                       ratio_embree_full_to_single=embree / single_sub, ratio_embree_full_to_batched=embree / batched_ms,
                       ratio_embree_bisection_to_single=embree_bis / single_sub,
                       ratio_embree_bisection_to_batched=embree_bis / batched_ms)
    path = write_figures(args.out, figures, dem_cells=args.size, image=[args.width, args.height], repeats=args.repeats)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
