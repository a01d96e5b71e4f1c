import json, sys, numpy as np
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams
from skyrender.localizer import pipeline as pl
from skyrender.features import load_photo
views = json.load(open("/tmp/s22/views.json"))
which, i = sys.argv[1], int(sys.argv[2])
model = load_model(f"/tmp/s22/model-{which}"); terrain = Terrain(model.dem)
v = views[i]; truth = np.array(v["pose"])
log = []
orig_solver = pl.solve_poses
def solver(*a, **kw):
    poses, res = orig_solver(*a, **kw)
    d = np.hypot(*(poses[:, :2] - truth[:2]).T)
    dp = np.abs((poses[:, 3] - truth[3] + 180) % 360 - 180)
    near = np.flatnonzero((d < 1500) & (dp < 20))
    log.append((len(poses), near, d[near], res[near], poses[near]))
    return poses, res
orig_apply = pl._apply
rej = {}
def apply(idx, ok, stats, name):
    out = orig_apply(idx, ok, stats, name)
    rej.setdefault(name, []).append(np.setdiff1d(idx, out))
    return out
pl._apply = apply
params = LocalizeParams.preset("render")
r = pl.localize(load_photo(v["photo"]), model, 2.0, v["fov"], terrain=terrain, params=params, solver=solver)
print(r.status, r.hypotheses)
chunks = len(log)
for c, (n, near, d, res, poses) in enumerate(log):
    if len(near) == 0: continue
    fates = []
    for j, idx in enumerate(near):
        fate = "residual" if res[j] > params.residual_px else "ok"
        if fate == "ok":
            for name, lst in rej.items():
                if c < len(lst) and idx in lst[c]: fate = name
        fates.append(f"{d[j]:.0f}m r{res[j]:.2f} {fate}")
    print("chunk", c, "near", len(near), "; ".join(fates[:12]))
