import json, sys, numpy as np, time
from dataclasses import replace
from skyrender.model import load_model
from skyrender.render import Terrain
from skyrender.localizer import LocalizeParams
from skyrender.localizer import pipeline as pl
from skyrender.localizer.refinement import refine_pose
from skyrender.features import load_photo
views = json.load(open("/tmp/s22/views.json"))
which, i = sys.argv[1], int(sys.argv[2])
model = load_model(f"/tmp/s22/model-{which}"); terrain = Terrain(model.dem)
captured = {}
orig = pl._decide
def spy(search, accepted, t):
    captured["s"] = search
    return orig(search, accepted, t)
pl._decide = spy
params = LocalizeParams.preset("render")
v = views[i]; truth = np.array(v["pose"])
r = pl.localize(load_photo(v["photo"]), model, 2.0, v["fov"], terrain=terrain, params=params)
s = captured["s"]
ref = [c for c in s.candidates if c.refined is not None]
ref.sort(key=lambda c: c.refined.score)
for c in ref[:4]:
    k = s.intrinsics(v["fov"])
    d0 = np.hypot(*(c.pose[:2]-truth[:2])); d1 = np.hypot(*(c.refined.pose[:2]-truth[:2]))
    t = time.perf_counter()
    rr = refine_pose(terrain, c.pose, k, 2.0, s.sky, s.weights, params=params.score, refine=params.refine, f_px=c.f_px)
    dt = time.perf_counter() - t
    d2 = np.hypot(*(rr.pose[:2]-truth[:2]))
    print(f"start {d0:.0f} m ({'3pt' if c.points is not None else 'hz'}) -> refined {d1:.0f} m {c.refined.score:.3f} agree {c.refined.agreement:.3f}; without points -> {d2:.0f} m {rr.score:.3f} agree {rr.agreement:.3f} ({dt:.1f}s)", flush=True)
