import time
import numpy as np
from dataclasses import replace
from skyrender.benchmarks.views import sample_views
from skyrender.camera import Intrinsics
from skyrender.dem.synthetic import fractal_terrain
from skyrender.localizer import LocalizeParams, localize
from skyrender.localizer.params import PHOTO_TELEPHOTO_FOVS, PHOTO_TELEPHOTO_STEPS
from skyrender.model import build_model
from skyrender.render import Terrain
from skyrender.render.photo import Look, render_photo
dem = fractal_terrain(); terrain = Terrain(dem); model = build_model(dem, terrain=terrain)
K = Intrinsics.from_fov(60.0, 640, 480)
views = sample_views(terrain, model, K, 5, seed=1)
tele = Intrinsics.from_fov(16.0, 640, 480)
for i in range(5):
    pose = views.poses[i]
    img = render_photo(terrain, pose, tele, Look()).image
    for name, p in (("render", LocalizeParams()), ("render+tele", LocalizeParams(telephoto_fovs=PHOTO_TELEPHOTO_FOVS, telephoto_fov_step=PHOTO_TELEPHOTO_STEPS))):
        t = time.perf_counter()
        r = localize(img, model, 2.0, None, terrain=terrain, params=p)
        e = np.hypot(*(r.pose[:2] - pose.array()[:2])) if r.pose is not None else float('nan')
        print(i, name, r.status, round(float(e), 1), r.fov and round(r.fov, 2), round(r.confidence, 2), round(time.perf_counter() - t, 1), flush=True)
