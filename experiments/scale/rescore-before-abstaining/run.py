"""run.py MODEL VIEWS_JSON ids OVERRIDES_JSON -> status/error per view"""
import json, sys, time, numpy as np
from dataclasses import replace
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams, localize
from skyrender.features import load_photo
model = load_model(sys.argv[1]); terrain = Terrain(model.dem)
views = json.load(open(sys.argv[2]))
ids = range(len(views)) if sys.argv[3] == "all" else [int(a) for a in sys.argv[3].split(",")]
params = replace(LocalizeParams.preset("render"), **json.loads(sys.argv[4]))
for i in ids:
    v = views[i]; truth = np.array(v["pose"])
    t = time.perf_counter()
    r = localize(load_photo(v["photo"]), model, 2.0, v["fov"], terrain=terrain, params=params)
    err = None if r.pose is None else round(float(np.hypot(*(r.pose[:2] - truth[:2]))), 2)
    esc = r.stats.seconds.get("escalation", 0.0)
    print(f"{sys.argv[2].split('/')[-1]} view {i}: {r.status} err {err} conf {r.confidence:.3f} {time.perf_counter()-t:.1f}s (escalation {esc:.1f}s) best {r.stats.best_score} ru {r.stats.runner_up_score}", flush=True)
