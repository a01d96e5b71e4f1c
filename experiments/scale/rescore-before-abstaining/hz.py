import json, sys, numpy as np
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import horizon_poses
from skyrender.localizer.verification import verify_poses
from skyrender.camera import Intrinsics
views = json.load(open("/tmp/s22/views.json"))
params = LocalizeParams.preset("render")
i = int(sys.argv[1])
v = views[i]; truth = np.array(v["pose"])
for which in ("tile", "tile1"):
    model = load_model(f"/tmp/s22/model-{which}"); terrain = Terrain(model.dem)
    sky = np.load(f"/tmp/s22/sky-tile-{i}.npy"); w = np.ones_like(sky)
    k = Intrinsics.from_fov(v["fov"], len(sky), 756)
    poses, cost = horizon_poses(model.horizons, sky, w, k, model.dem, 2.0, params.horizon)
    score, trusted = verify_poses(terrain, poses, k, sky, w, params.verify_stride, params=params.score)
    d = np.hypot(*(poses[:, :2] - truth[:2]).T)
    dc = np.hypot(*(model.horizons.centres[:, :2] - truth[:2]).T)
    print(which, "poses", len(poses), "nearest centre", np.sort(dc)[:3].round(0), "nearest poses", np.sort(d)[:5].round(0))
    rs = np.argsort(np.argsort(score)); rt = np.argsort(np.argsort(trusted)); rc = np.arange(len(cost))
    for j in np.argsort(d)[:6]:
        print(f"  d {d[j]:.0f} pan {poses[j,3]:.0f} (true {truth[3]:.0f}) cost {cost[j]:.4f} rank {rc[j]} score {score[j]:.2f} rank {rs[j]} trusted {trusted[j]:.2f} rank {rt[j]}")
