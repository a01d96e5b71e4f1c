"""Does aerial perspective tell the right place from a look-alike? (a probe, 2026-12-05)

``python experiments/ch1/haze/haze_cue.py ROWS.json [ROWS.json ...] --out OUT.json``

For each localization row (``real_localize`` JSON or ``confidence-train-rows.json``) the answer
(best refined pose) and its runner-up (the best refined pose beyond 1 km) are rendered at the photo's
size with the distance of each column's skyline terrain. Distant ridges are paler: the photo's
colour contrast between sky and terrain across its skyline should fall with the rendered distance
at the right place, not at a look-alike whose ridges lie at other distances. Per pose: the Spearman
correlation of the photo's contrast (Lab distance of rows 3-6 above the extracted skyline from rows
2-5 below) with the rendered distance, over the columns where the rendered skyline lies within 3 px
of the photo's.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from scipy.stats import spearmanr

from skyrender.benchmarks.real_localize import refined_of
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.dem import load_dem
from skyrender.diagnostics.oracle import DEM_DIR, tiles_around
from skyrender.features import extract_skyline, load_photo
from skyrender.features.sky import pixel_features
from skyrender.localizer import LocalizeParams
from skyrender.localizer.confidence import runner_up_index
from skyrender.render import Terrain
from skyrender.render.skyline import render_skylines

MATCH_PX = 3.0


def photo_contrast(features: np.ndarray, skyline: np.ndarray) -> np.ndarray:
    """(W,) Lab distance between the mean of rows v-6..v-3 (sky) and v+2..v+5 (terrain) per column."""
    H, W = features.shape[:2]
    lab = features[..., :3].astype(np.float64)
    cols = np.arange(W)
    v = np.round(np.nan_to_num(skyline, nan=-100)).astype(int)

    def mean_rows(offsets):
        r = np.clip(v[None, :] + np.array(offsets)[:, None], 0, H - 1)
        return lab[r, cols[None, :]].mean(axis=0)

    c = np.linalg.norm(mean_rows([-6, -5, -4, -3]) - mean_rows([2, 3, 4, 5]), axis=1)
    return np.where((v > 6) & (v < H - 6), c, np.nan)


def cue(rendered: np.ndarray, distance: np.ndarray, skyline: np.ndarray, contrast: np.ndarray) -> tuple[float, int]:
    ok = (np.isfinite(rendered) & np.isfinite(skyline) & np.isfinite(distance) & np.isfinite(contrast)
          & (np.abs(rendered - skyline) <= MATCH_PX))
    if ok.sum() < 40 or np.ptp(distance[ok]) < 1000:
        return float("nan"), int(ok.sum())
    return float(spearmanr(contrast[ok], distance[ok]).correlation), int(ok.sum())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("rows", nargs="+")
    ap.add_argument("--out", required=True)
    ap.add_argument("--fov-mode", default="known")
    a = ap.parse_args()
    rows = []
    for path in a.rows:
        d = json.load(open(path))
        rows += [r for r in d.get("rows", d.get("photos", [])) if r.get("fov_mode", "known") == a.fov_mode]
    items = {it.key: it for side in ("train", "dev", "validation") for it in items_on_side(side)}
    params = LocalizeParams.for_photos()
    out, loaded = [], {}
    for n, row in enumerate(rows):
        it = items[row["photo"]]
        window = tuple(row["window"])
        if window not in loaded:
            loaded.clear()
            clat, clon = 0.5 * (window[1] + window[3]), 0.5 * (window[0] + window[2])
            dem = load_dem(tiles_around(clat, clon, DEM_DIR), bounds=window)
            loaded[window] = (dem, Terrain(dem))
        dem, terrain = loaded[window]
        poses = refined_of(row)
        rec = {"photo": row["photo"], "error_m": row.get("error_m"), "confidence": row["confidence"]}
        if len(poses):
            image = load_photo(it.image_path)
            H, W = image.shape[:2]
            ext = extract_skyline(image, params.skyline_params())
            contrast = photo_contrast(pixel_features(image), ext.skyline)
            best = int(np.argmin(poses[:, 7]))
            ru = runner_up_index(poses[:, :2], poses[:, 7], best, 1000.0)
            picks = [best] + ([ru] if ru is not None else [])
            k = np.array([[poses[i, 6], W / 2.0, H / 2.0] for i in picks])
            sky, dist = render_skylines(terrain, poses[picks, :6], Intrinsics(W, H, float(poses[best, 6]), W / 2.0, H / 2.0),
                                        per_pose_intrinsics=k, with_distance=True)
            for name, j in zip(("best", "runner_up"), range(len(picks))):
                c, m = cue(sky[j], dist[j], ext.skyline, contrast)
                rec[name] = {"corr": c, "matched": m, "score": float(poses[picks[j], 7]),
                             "median_km": float(np.nanmedian(np.where(np.isfinite(dist[j]), dist[j], np.nan)) / 1000)}
            rec["truth_dist_m"] = float(np.hypot(*(poses[best, :2] - np.asarray(row["truth_xy"]))))
        out.append(rec)
        b = rec.get("best", {})
        print(f"[{n + 1}/{len(rows)}] {row['photo']} err {rec['error_m'] or -1:.0f} conf {rec['confidence']:.2f} "
              f"corr best {b.get('corr', np.nan):+.2f} ({b.get('matched', 0)}) runner "
              f"{rec.get('runner_up', {}).get('corr', np.nan):+.2f}", flush=True)
    json.dump(out, open(a.out, "w"), indent=1)


if __name__ == "__main__":
    main()
