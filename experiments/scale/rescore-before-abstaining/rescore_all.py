import json, sys, time, os, numpy as np
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams
from skyrender.localizer.pipeline import _image_skyline
from skyrender.localizer.horizon_search import horizon_poses
from skyrender.localizer.refinement import local_rescore
from skyrender.camera import Intrinsics
from skyrender.features import load_photo
views = json.load(open(sys.argv[2]))
params = LocalizeParams.preset("render")
model = load_model(sys.argv[1]); terrain = Terrain(model.dem)
configs = json.loads(sys.argv[4])
for i in [int(a) for a in sys.argv[3].split(",")]:
    v = views[i]; truth = np.array(v["pose"])
    cache = v["photo"] + ".sky.npz"
    if os.path.exists(cache):
        z = np.load(cache); sky, w, H = z["sky"], z["w"], int(z["H"])
    else:
        sky, w, W, H = _image_skyline(load_photo(v["photo"]), None, params.skyline_params(), params.confidence_power)
        np.savez(cache, sky=sky, w=w, H=H)
    k = Intrinsics.from_fov(v["fov"], len(sky), H)
    poses, cost = horizon_poses(model.horizons, sky, w, k, model.dem, 2.0, params.horizon)
    for stride, n, half in configs:
        t = time.perf_counter()
        moved, score = local_rescore(terrain, poses, k, 2.0, sky, w, half, n, stride, params.score)
        dt = time.perf_counter() - t
        d = np.hypot(*(moved[:, :2] - truth[:2]).T)
        order = np.argsort(score, kind="stable")
        near = np.flatnonzero(d[order] < 300)
        print(f"{sys.argv[2].split('/')[-1]} view {i} stride {stride} grid {n} half {half}: {len(poses)} poses {dt:.1f}s; nearest {np.sort(d)[:2].round(0)}; ranks within 300 m: {near[:3]} scores {score[order][near[:3]].round(2)} best {score[order][:3].round(2)}", flush=True)
