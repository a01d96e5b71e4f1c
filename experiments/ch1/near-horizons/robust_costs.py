"""Does a robust matching cost rank the right place first where least squares does not? (a probe, 2026-12-05)

``python experiments/ch1/near-horizons/robust_costs.py OUT.json [--random N] [--cache DIR] [--photos KEY ...]``

The same centres as ``probe.py`` (a 100 m grid within 500 m of the truth and N seeded random centres over the
search window; horizons from 300 m, as the photo model's, cached per photo in DIR), the photo's extracted
skyline turned into directions for the photo preset's tilts, and every (centre, azimuth) pair scored by brute
force over the whole skyline (no windows) after the weighted least-squares fit of offset + slope, with
- ``ls``: the weighted mean squared residual (the far-horizon search's cost, without its windows);
- ``trunc``: the weighted mean of min(r^2, 1 deg^2) of the same residuals;
- ``huber``: one reweighting (Huber, 0.5 deg), the fit redone, the weighted mean Huber loss.
Reported per photo and cost: the rank of the best centre within 250 m of the truth among all centres (each
centre by its best azimuth and tilt).
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

from skyrender.benchmarks.real_localize import place_window, places_of
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem import load_dem
from skyrender.diagnostics.oracle import DEM_DIR, tiles_around
from skyrender.features import extract_skyline, load_photo
from skyrender.localizer import LocalizeParams
from skyrender.localizer.horizon_search import skyline_directions
from skyrender.localizer.pipeline import column_weights
from skyrender.render import Terrain
from skyrender.render.horizon import render_horizons

NEAR_SKYLINES = ["ch1/IMG_4923_01024", "ch1/IMG_5141_01024", "ch1/IMG_5181_01024", "ch1/IMG_5195_01024",
                 "ch1/2011-04-30_18-37-52_01024", "ch1/2011-10-01_17-15-04_01024", "ch1/2011-10-01_17-19-13_01024",
                 "ch1/IMG_5045_01024", "ch1/IMG_5156_01024"]


def horizons_for(it, window, n_random: int, cache: str):
    path = os.path.join(cache, it.key.replace("/", "__") + f"-{n_random}.npz")
    dem = load_dem(tiles_around(it.lat, it.lon, DEM_DIR), bounds=window)
    tx, ty = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
    if os.path.exists(path):
        z = np.load(path)
        return z["xy"], z["elevation"].astype(np.float32), z["is_near"], (tx, ty)
    xmin, xmax, ymin, ymax = dem.extent
    rng = np.random.default_rng(0)
    far = np.column_stack([rng.uniform(xmin + 2000, xmax - 2000, n_random), rng.uniform(ymin + 2000, ymax - 2000, n_random)])
    g = np.arange(-500.0, 501.0, 100.0)
    near = np.column_stack([tx + np.repeat(g, len(g)), ty + np.tile(g, len(g))])
    xy = np.vstack([near, far])
    zc = dem.ground(xy[:, 0], xy[:, 1]) + 2.0
    ok = np.isfinite(zc)
    is_near = np.arange(len(ok))[ok] < len(near)
    xy, zc = xy[ok], zc[ok]
    elevation = render_horizons(Terrain(dem), np.column_stack([xy, zc]), bin_deg=1.0, near_m=300.0)
    np.savez(path, xy=xy, elevation=elevation.astype(np.float16), is_near=is_near)
    return xy, elevation, is_near, (tx, ty)


def costs_of(P: np.ndarray, bins: np.ndarray, e: np.ndarray, w: np.ndarray, block: int = 500) -> dict:
    """(N,) best over azimuth of each cost, for horizons P (N, 360) and the photo's directions."""
    alpha = np.radians(bins.astype(np.float64))
    X = np.column_stack([np.ones_like(alpha), alpha])
    sw = np.sqrt(w)
    out = {k: np.empty(len(P)) for k in ("ls", "trunc", "huber")}
    idx = (np.arange(360)[:, None] + bins[None, :]) % 360  # (360, n): horizon bin seen by each skyline bin
    Xw = X * sw[:, None]
    pinv = np.linalg.pinv(Xw)  # (2, n)
    wsum = w.sum()
    for lo in range(0, len(P), block):
        r = P[lo:lo + block][:, idx].astype(np.float64) - e[None, None, :]  # (B, 360, n) horizon - photo
        rw = r * sw
        coef = rw @ pinv.T  # (B, 360, 2)
        res = r - coef @ X.T  # residuals after the LS fit
        sq = res * res
        out["ls"][lo:lo + block] = ((sq * w).sum(-1) / wsum).min(-1)
        out["trunc"][lo:lo + block] = ((np.minimum(sq, 1.0) * w).sum(-1) / wsum).min(-1)
        # Huber, one reweighting: weights w min(1, c / |res|), refit, loss
        c = 0.5
        hw = w * np.minimum(1.0, c / np.maximum(np.abs(res), 1e-9))
        A = np.einsum("bzn,ni,nj->bzij", hw, X, X)
        b = np.einsum("bzn,bzn,ni->bzi", hw, r, X)
        coef2 = np.linalg.solve(A + 1e-9 * np.eye(2), b[..., None])[..., 0]
        res2 = np.abs(r - coef2 @ X.T)
        loss = np.where(res2 <= c, 0.5 * res2 * res2, c * (res2 - 0.5 * c))
        out["huber"][lo:lo + block] = ((loss * w).sum(-1) / wsum).min(-1)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--random", type=int, default=20000)
    ap.add_argument("--cache", default="/tmp/near-horizons-cache")
    ap.add_argument("--photos", nargs="+", default=NEAR_SKYLINES)
    a = ap.parse_args()
    os.makedirs(a.cache, exist_ok=True)
    items = {it.key: it for side in ("train", "dev") for it in items_on_side(side) if it.key.startswith("ch1/")}
    place_of, centres_of = places_of(items.values())
    params = LocalizeParams.for_photos()
    rows = []
    for key in a.photos:
        it = items[key]
        xy, P, is_near, (tx, ty) = horizons_for(it, place_window(*centres_of[place_of[key]]), a.random, a.cache)
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        ext = extract_skyline(image, params.skyline_params())
        weights = column_weights(ext.confidence)
        K = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        best = None
        for tilt in params.horizon.tilts:
            bins, e, w = skyline_directions(ext.skyline, weights, K, 1.0, tilt)
            if len(bins) < 12:
                continue
            c = costs_of(P, bins, e, w)
            best = c if best is None else {k: np.minimum(best[k], c[k]) for k in c}
        near_truth = np.hypot(xy[:, 0] - tx, xy[:, 1] - ty) <= 250.0
        rec = {"photo": key, "centres": int(len(xy))}
        for k, v in best.items():
            rec[k] = int(np.sum(v < v[near_truth].min())) + 1
        rows.append(rec)
        print(rec, flush=True)
    json.dump(rows, open(a.out, "w"), indent=1)


if __name__ == "__main__":
    main()
