import numpy as np, time
from dataclasses import replace
from scipy import ndimage
from skyrender.benchmarks.views import sample_views
from skyrender.camera import Intrinsics
from skyrender.dem.synthetic import fractal_terrain
from skyrender.localizer import LocalizeParams, localize
from skyrender.model import build_model
from skyrender.render import Terrain
from skyrender.render.photo import Look, render_photo
K = Intrinsics.from_fov(60.0, 640, 480)
dem = fractal_terrain(); terrain = Terrain(dem); model = build_model(dem, terrain=terrain)
views = sample_views(terrain, model, K, 5, seed=1)
rng = np.random.default_rng(0)
bump = ndimage.gaussian_filter(rng.standard_normal(dem.shape), 3.0)
for amp in (15.0, 30.0):
    world = replace(dem, elevation=dem.elevation + amp * bump / bump.std())
    wt = Terrain(world)
    for i, p in enumerate(views.poses):
        pose = world.camera_pose(p.x, p.y, 2.0, p.pan, p.tilt, p.swing)
        photo = render_photo(wt, pose, K, Look()).image
        out = []
        for n in (0, 4):
            t = time.perf_counter()
            r = localize(photo, model, 2.0, 60.0, terrain=terrain, params=LocalizeParams(min_confidence=1.01, escalate_refinements=0, free_refinements=n))
            best = np.array(r.stats.refined_poses)[np.argmin(np.array(r.stats.refined_poses)[:, 7])]
            out.append(f"free {n}: refined {r.stats.refined} best {r.stats.best_score:.3f} at {np.hypot(best[0]-p.x, best[1]-p.y):.0f} m ({time.perf_counter()-t:.1f}s)")
        print(amp, i, " | ".join(out), flush=True)
