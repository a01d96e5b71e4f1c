"""Terrain at the true camera positions against the localizer's refined candidates: the ground's slope
(DEM.slope_deg) and the height above the mean of the 1 km square around.

    python experiments/ch1/standable/terrain_stats.py experiments/ch1/confidence-train-rows.json OUT.json
"""
import json, sys
import numpy as np
from scipy import ndimage
from skyrender.benchmarks.real_localize import load_place, places_of
from skyrender.datasets.real_photos import items_on_side

rows = json.load(open(sys.argv[1]))["rows"]
items = {it.key: it for side in ("train", "dev") for it in items_on_side(side)}
place_of, centres = places_of([items[r["photo"]] for r in rows])
out = []
cache = {}
for r in rows:
    place = place_of[r["photo"]]
    if place not in cache:
        cache.clear()
        dem = load_place(*centres[place])[0]
        z = dem.elevation.astype(np.float64)
        dx, dy = dem.cell_size
        gy, gx = np.gradient(z, dy, dx)
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
        k = int(round(500 / dx))
        mean = ndimage.uniform_filter(z, 2 * k + 1)
        tpi = z - mean  # height above the 1 km square's mean
        cache[place] = (dem, slope, tpi)
    dem, slope, tpi = cache[place]
    def slope_at(x, y):
        return dem.slope_deg(np.asarray(x, float), np.asarray(y, float))

    def at(a, x, y):
        c, rr = dem.fractional_index(np.asarray(x), np.asarray(y))
        return a[np.clip(np.round(rr).astype(int), 0, a.shape[0]-1), np.clip(np.round(c).astype(int), 0, a.shape[1]-1)]
    tx, ty = r["truth_xy"]
    P = np.array(r["refined_poses"])
    d = np.hypot(P[:, 0] - tx, P[:, 1] - ty)
    out.append({"photo": r["photo"], "place": place, "truth": [float(slope_at(tx, ty)), float(at(tpi, tx, ty))],
                "poses": [[float(a), float(b), float(dd), float(s)] for a, b, dd, s in zip(slope_at(P[:,0], P[:,1]), at(tpi, P[:,0], P[:,1]), d, P[:, 7])]})
json.dump(out, open(sys.argv[2], "w"))
T = np.array([o["truth"] for o in out])
W = np.array([p[:2] for o in out for p in o["poses"] if p[2] > 1000])
R = np.array([p[:2] for o in out for p in o["poses"] if p[2] <= 1000])
for name, A in (("truth", T), ("refined within 1 km", R), ("refined wrong", W)):
    print(f"{name:22s} n={len(A):4d} slope median {np.median(A[:,0]):5.1f} p75 {np.percentile(A[:,0],75):5.1f} p90 {np.percentile(A[:,0],90):5.1f} | tpi median {np.median(A[:,1]):6.1f} p25 {np.percentile(A[:,1],25):6.1f} p75 {np.percentile(A[:,1],75):6.1f}")
