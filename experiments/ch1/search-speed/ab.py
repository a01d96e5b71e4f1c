"""The far-horizon search with each block of centres keeping its own best fits (``best_horizon_fits``) against
the whole (N, n_bins) costs stored and then searched (``horizon_costs`` + ``smallest``, the code before
2026-12-05 session 17), timed in one process on the same photos, alternating, each photo's outputs compared.

``python experiments/ch1/search-speed/ab.py [--photos N] > experiments/ch1/search-speed/ab.txt``

Per training-side CH1 photo (the first N; the training side's CH1 photos are all of place11): its place's model
(the photo preset's, cached), the skyline the localizer extracts, and ``horizon_poses`` with the photo preset's
search (5 tilts x 5 windows) at the three coarse fovs the fov-unknown mode searches (35, 50, 65 deg) and at the
photo's own fov, twice each way, alternating; the faster of the two repeats per way counts. Training side only: this
measures speed, and the poses either way must be the same to the bit. (``ab.txt`` was made at 525fc5c, whose copy
picked the same first 6 photos by a longer rule.)
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from skyrender.benchmarks.real_localize import load_place, places_of
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.evaluate import git_commit
from skyrender.features import load_photo
from skyrender.localizer import LocalizeParams, horizon_search
from skyrender.localizer.params import PHOTO_FOV_CANDIDATES
from skyrender.localizer.pipeline import _image_skyline, reduce_skyline


def whole_arrays(spectra, n_bins, bins, elevation, weights, bin_deg, k, terms=3, max_swing_deg=np.inf):
    """The baseline: every cost and fit coefficient stored, then the best ``k`` searched in one thread."""
    cost, offset_at = horizon_search.horizon_costs(spectra, n_bins, bins, elevation, weights, bin_deg, terms,
                                                   max_swing_deg)
    best = horizon_search.smallest(cost, k)
    return best, cost.ravel()[best], offset_at(best)


def timed(way, *args):
    horizon_search.best_horizon_fits = way
    t = time.perf_counter()
    out = horizon_search.horizon_poses(*args)
    return time.perf_counter() - t, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=6)
    args = parser.parse_args()
    blocked = horizon_search.best_horizon_fits
    params = LocalizeParams.for_photos()
    items = [it for it in items_on_side("train") if it.key.startswith("ch1/")]
    place_of, centres = places_of(items)
    chosen = items[: args.photos]
    print(f"commit {git_commit()}; {len(chosen)} training-side CH1 photos; horizon_poses, photo preset, seconds "
          f"(best of 2 per way)")
    print(f"{'photo':28s} {'fov':>5s} {'poses':>6s} {'whole arrays':>12s} {'blocks':>7s} {'ratio':>6s} same")
    totals = np.zeros(2)
    for it in chosen:
        dem, terrain, model, _ = load_place(*centres[place_of[it.key]])
        image = load_photo(it.image_path)
        sky, w, W, H = _image_skyline(image, None, params.skyline_params(), params.confidence_power)
        if W > params.search_width:
            sky, w, W, H = reduce_skyline(sky, w, W, H, params.search_width)
        own = float(np.degrees(2 * np.arctan(image.shape[1] / (2 * it.focal_px))))
        for fov in (*PHOTO_FOV_CANDIDATES, own):
            call = (model.horizons, sky, w, Intrinsics.from_fov(fov, W, H), model.dem, 2.0, params.horizon)
            seconds = {0: [], 1: []}
            outs = {}
            for _ in range(2):
                for way, fn in ((0, whole_arrays), (1, blocked)):
                    s, outs[way] = timed(fn, *call)
                    seconds[way].append(s)
            same = all(np.array_equal(a, b) for a, b in zip(outs[0], outs[1]))
            best = np.array([min(seconds[0]), min(seconds[1])])
            totals += best
            print(f"{it.key:28s} {fov:5.1f} {len(outs[1][0]):6d} {best[0]:12.2f} {best[1]:7.2f} "
                  f"{best[0] / best[1]:6.2f} {'yes' if same else 'NO'}", flush=True)
    horizon_search.best_horizon_fits = blocked
    print(f"total: whole arrays {totals[0]:.1f} s, blocks {totals[1]:.1f} s, ratio {totals[0] / totals[1]:.2f}")


if __name__ == "__main__":
    main()
