"""View 4 of the tile row on the 1" tile: where its near-truth far-horizon pose ranks."""
import os, sys, time, json, numpy as np
from skyrender.diagnostics.search_rounds import tile_views
from skyrender.benchmarks.scale import write_one_arc_second_tile, DEM_DIR, TILE
from skyrender.dem import load_dem
from skyrender.render import Terrain
from skyrender.model import cached_model
from skyrender.features import extract_skyline, load_photo
from skyrender.localizer import LocalizeParams, localize
from skyrender.localizer.horizon_search import horizon_poses
from skyrender.localizer.pipeline import column_weights
from skyrender.localizer.verification import verify_poses
from skyrender.camera import Intrinsics
tmp = sys.argv[1]; which = [int(v) for v in sys.argv[2].split(',')]
os.makedirs(tmp, exist_ok=True)
_, _, views = tile_views(8, 0, tmp)
one = os.path.join(tmp, "one.tif")
if not os.path.exists(one):
    write_one_arc_second_tile(os.path.join(DEM_DIR, TILE), one)
dem = load_dem(one); terrain = Terrain(dem)
t = time.perf_counter(); model = cached_model(dem, terrain=terrain); print("model", time.perf_counter() - t)
params = LocalizeParams()
for i in which:
    path, fov, pose = views[i]
    image = load_photo(path); H, W = image.shape[:2]
    ex = extract_skyline(image, params.skyline_params())
    w = column_weights(ex.confidence, params.confidence_power)
    k = Intrinsics.from_fov(fov, W, H)
    poses, cost = horizon_poses(model.horizons, ex.skyline, w, k, dem, 2.0, params.horizon)
    score, trusted = verify_poses(terrain, poses, k, ex.skyline, w, params.verify_stride, params=params.score)
    d = np.hypot(poses[:, 0] - pose[0], poses[:, 1] - pose[1])
    out = {"view": i, "fov": fov, "poses": len(poses), "nearest": float(d.min())}
    for name, v in (("cost", cost), ("score", score), ("trusted", trusted)):
        order = np.argsort(v, kind="stable")
        for r in (200, 500, 1000):
            hit = np.flatnonzero(d[order] <= r)
            out[f"{name}{r}"] = int(hit[0]) + 1 if len(hit) else None
    j = np.argsort(d)[:3]
    out["near"] = [(float(d[x]), float(cost[x]), float(score[x]), float(trusted[x])) for x in j]
    print(json.dumps(out), flush=True)
    t = time.perf_counter()
    res = localize(image, model, 2.0, fov, terrain=terrain, skyline=ex, params=params)
    err = None if res.pose is None else float(np.hypot(res.pose[0] - pose[0], res.pose[1] - pose[1]))
    rp = np.asarray(res.stats.refined_poses).reshape(-1, 8)
    rd = np.hypot(rp[:, 0] - pose[0], rp[:, 1] - pose[1])
    print(json.dumps({"view": i, "status": res.status, "err": err, "conf": res.confidence, "s": time.perf_counter() - t,
                      "refined": [(round(float(a), 1), round(float(b), 3)) for a, b in zip(rd, rp[:, 7])]}), flush=True)
