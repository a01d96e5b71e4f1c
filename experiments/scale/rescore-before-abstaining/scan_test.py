import numpy as np, time
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
for i, p in enumerate(views.poses):
    photo = render_photo(terrain, p, K, Look()).image
    out = []
    for n in (0, 6):
        t = time.perf_counter()
        r = localize(photo, model, 2.0, 60.0, terrain=terrain, params=LocalizeParams(n_peaks=2, max_horizon_refinements=1, final_refinements=1, escalate_refinements=0, rescore_refinements=n))
        err = None if r.pose is None else round(float(np.hypot(r.pose[0]-p.x, r.pose[1]-p.y)), 1)
        out.append(f"rescore {n}: {r.status} {err} conf {r.confidence:.2f} refined {r.stats.refined} ({time.perf_counter()-t:.1f}s)")
    print(i, " | ".join(out), flush=True)
