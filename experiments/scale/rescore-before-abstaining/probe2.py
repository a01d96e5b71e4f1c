import json, sys, numpy as np
from dataclasses import replace
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams
from skyrender.localizer import pipeline as pl
from skyrender.features import load_photo
model = load_model(sys.argv[1]); terrain = Terrain(model.dem)
views = json.load(open(sys.argv[2])); i = int(sys.argv[3])
params = replace(LocalizeParams.preset("render"), **json.loads(sys.argv[4]))
v = views[i]; truth = np.array(v["pose"])
r = pl.localize(load_photo(v["photo"]), model, 2.0, v["fov"], terrain=terrain, params=params)
print(r.status, r.confidence, r.stats.seconds)
rp = np.array(r.stats.refined_poses)
d = np.hypot(rp[:, 0] - truth[0], rp[:, 1] - truth[1])
for j in np.argsort(d)[:6]:
    print(f"  #{j} of {len(rp)}: {d[j]:.0f} m score {rp[j, 7]:.3f} pan {rp[j,3]:.1f} (true {truth[3]:.1f})")
