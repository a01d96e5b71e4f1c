"""A pixel classifier above the skyline, for far ridges taken for sky (a probe, 2026-12-05; not shipped).

``python experiments/photos/lift-classifier/probe.py [FEATURES]`` (from the repository root; ~4 min)

The commonest way the ``select`` extractor misses on CH1 is a far, hazy ridge above the found line taken for sky
(the extracted line lies > 5 px below the mask's on 5-29 % of the columns of 8 of the 27 training-side misses of
place11 and of 4 of the 8 dev misses). This probe fits a gradient-boosted pixel classifier (scikit-learn) on the
training photos' pixels in a band from 64 px above to 8 px below the selected boundary, with cues of this photo's
clear sky (colour off the robust quadratic sky field, :func:`skyrender.features.sky.clear_sky_field`, in Lab and
in robust sigmas; texture, gradient; how much of the column between the pixel and the boundary is off the field;
the row offset; the extractor's own log-odds), puts its P(terrain) into the band, and runs the extractor's boundary
search again (the same weights). Reported: per side, the photos meeting the target and the mean share within 5 px,
before and after, and every photo that moves by more than a point. FEATURES: comma-separated column indices of
:func:`band_features` (default: all).
"""

from __future__ import annotations

import sys

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.cables import remove_cables
from skyrender.features.sky import clear_sky_field, pixel_features
from skyrender.features.skyline import SkylineParams, _boundary, _edge_strength, _subpixel, _texture_cost, boundary_skyline

ABOVE, BELOW, BAND = 64, 8, 6
PARAMS = SkylineParams(method="select")
NAMES = ["dL", "da", "db", "dE/sigma", "texture", "gradient", "log-odds", "row offset", "sigma", "field b",
         "field L", "off-field share below", "dE above"]


def band_features(f: np.ndarray, p: np.ndarray, sky: np.ndarray):
    """(H, W, 13) cues (NAMES), the band mask (H, W) and the boundary rows (W,); None without a sky field."""
    H, W = p.shape
    v = np.arange(H)[:, None]
    cols = np.arange(W)[None, :]
    r = np.where(np.isfinite(sky), np.floor(sky), H).astype(int)
    fit = clear_sky_field(f, (v < r[None, :] - BAND) & (p > 0.5))
    if fit is None:
        return None
    field, sigma = fit
    d = f[..., :3] - field
    dE = np.sqrt((d ** 2).sum(-1)) / max(sigma, 1.0)
    rows = np.broadcast_to(v, (H, W))
    rc = np.broadcast_to(np.clip(r, 0, H)[None, :], (H, W))
    off = np.vstack([np.zeros((1, W)), np.cumsum(dE > 3, 0)])
    share_below = (off[rc, cols] - off[rows, cols]) / np.maximum(rc - rows, 1)
    csum = np.vstack([np.zeros((1, W)), np.cumsum(dE, 0)])
    up = np.clip(rows - 6, 0, H)
    above = (csum[rows, cols] - csum[up, cols]) / np.maximum(rows - up, 1)
    log_odds = np.log(np.clip(p, 1e-4, 1 - 1e-4) / np.clip(1 - p, 1e-4, 1))
    X = np.stack([d[..., 0], d[..., 1], d[..., 2], dE, f[..., 3], f[..., 4], log_odds, rows - r[None, :],
                  np.full((H, W), sigma), field[..., 2], field[..., 0], share_below, above], -1).astype(np.float32)
    band = (rows >= r[None, :] - ABOVE) & (rows < r[None, :] + BELOW)
    return X, band, r


def photos(sides):
    """Per photo: side, key, features, selected probability and skyline, truth (mask and skyline)."""
    for side in sides:
        for it in items_on_side(side):
            image = load_photo(it.image_path)
            if image.shape[1] > PARAMS.work_width:
                continue
            e = extract_skyline(image, PARAMS)
            f = pixel_features(remove_cables(image, PARAMS.cables)[0])
            yield side, it.key, f, e.sky_probability, e.skyline, it.truth_mask(), it.truth_skyline()


def main(keep: list[int] | None) -> None:
    from sklearn.ensemble import HistGradientBoostingClassifier

    rng = np.random.default_rng(0)
    data, Xs, ys = [], [], []
    for side, key, f, p, sky, mask, truth in photos(["train", "dev"]):
        out = band_features(f, p, sky)
        data.append((side, key, f, p, sky, truth, out))
        if side == "train" and out is not None:
            X, band, _ = out
            idx = np.flatnonzero((band & (mask != 0.5)).ravel())
            idx = rng.choice(idx, min(len(idx), 8000), replace=False)
            Xs.append(X.reshape(-1, X.shape[-1])[idx])
            ys.append(mask.ravel()[idx] > 0.5)
    keep = keep or list(range(len(NAMES)))
    print("features:", ", ".join(NAMES[k] for k in keep))
    clf = HistGradientBoostingClassifier(max_iter=100, max_leaf_nodes=15, min_samples_leaf=500, random_state=0)
    clf.fit(np.concatenate(Xs)[:, keep], np.concatenate(ys))
    for side_name in ("train", "dev"):
        before, after = [], []
        for side, key, f, p, sky, truth, out in data:
            if side != side_name:
                continue
            e0 = column_errors(sky, truth)
            e1 = e0
            if out is not None:
                X, band, _ = out
                p2 = p.copy()
                p2[band] = clf.predict_proba(X[band][:, keep])[:, 0]
                rows = _boundary(p2, _edge_strength(f, PARAMS.edge_percentile), PARAMS.edge_bonus, PARAMS.jump_cost,
                                 PARAMS.jump_cap, _texture_cost(f, PARAMS.texture_weight))
                e1 = column_errors(boundary_skyline(rows, _subpixel(f, rows)[0], p.shape[0]), truth)
            before.append(e0)
            after.append(e1)
            if abs(np.mean(e0 <= 5) - np.mean(e1 <= 5)) > 0.01:
                print(f"  {side_name} {key:36s} median {np.median(e0):6.2f} -> {np.median(e1):6.2f} px, within 5 px "
                      f"{np.mean(e0 <= 5) * 100:5.1f} -> {np.mean(e1 <= 5) * 100:5.1f} %")
        met = [sum(meets_target(np.median(e), np.mean(e <= 5)) for e in es) for es in (before, after)]
        mean = [np.mean([np.mean(e <= 5) for e in es]) * 100 for es in (before, after)]
        print(f"{side_name} ({len(before)} photos): target met {met[0]} -> {met[1]}; mean within 5 px "
              f"{mean[0]:.1f} -> {mean[1]:.1f} %")


if __name__ == "__main__":
    main([int(k) for k in sys.argv[1].split(",")] if len(sys.argv) > 1 else None)
