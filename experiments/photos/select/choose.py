"""Step 2 of the selection probe: from ``extract.py``'s files, the target met and the mean share of columns
within 5 px per side for ``hybrid``, ``gmm`` and three ways of choosing between them where their skylines
part by more than 5 px (10 px): the photo's whole skyline from the one more confident on the disputed
columns (what ``method="select"`` ships, :func:`skyrender.features.skyline.select_skylines`), or each
stretch of disputed columns from the one more confident on it; then every photo the choice changes.

``python experiments/photos/select/choose.py CACHE_DIR dev train``
"""

from __future__ import annotations

import glob
import json
import os
import sys

import numpy as np
from scipy import ndimage

from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import REPO

SPLIT = json.load(open(os.path.join(REPO, "experiments", "photos", "split.json")))["photos"]


def key(path: str) -> str:
    return os.path.basename(path)[:-4].replace("__", "/")


def met(e: np.ndarray) -> bool:
    return meets_target(np.median(e), np.mean(e <= 5))


def choose(z, tol: float = 5.0, per_stretch: bool = False) -> np.ndarray:
    h, g, hc, gc = z["hybrid"], z["gmm"], z["hybrid_conf"], z["gmm_conf"]
    apart = np.abs(np.nan_to_num(h, nan=1e4) - np.nan_to_num(g, nan=1e4)) > tol
    if not per_stretch:
        return g if apart.any() and gc[apart].mean() > hc[apart].mean() else h
    out = h.copy()
    stretches, n = ndimage.label(apart)
    for i in range(1, n + 1):
        s = stretches == i
        if gc[s].mean() > hc[s].mean():
            out[s] = g[s]
    return out


def main(cache: str, sides: list[str]) -> None:
    for side in sides:
        files = [f for f in sorted(glob.glob(os.path.join(cache, "*.npz"))) if SPLIT[key(f)]["side"] == side]
        rows = {}
        for f in files:
            z = np.load(f)
            for name, skyline in (("hybrid", z["hybrid"]), ("gmm", z["gmm"]), ("select (photo)", choose(z)),
                                  ("per stretch", choose(z, per_stretch=True)),
                                  ("per stretch, 10 px", choose(z, 10.0, per_stretch=True))):
                e = column_errors(skyline, z["truth"])
                rows.setdefault(name, []).append((met(e), np.mean(e <= 5)))
        print(f"{side} ({len(files)} photos)")
        for name, v in rows.items():
            v = np.array(v)
            print(f"  {name:20s} met {int(v[:, 0].sum()):3d}  mean within 5 px {v[:, 1].mean():.1%}  lowest {v[:, 1].min():.1%}")
    print("photos the choice changes (share within 5 px, target met):")
    for side in sides:
        for f in sorted(glob.glob(os.path.join(cache, "*.npz"))):
            if SPLIT[key(f)]["side"] != side:
                continue
            z = np.load(f)
            eh, eg = column_errors(z["hybrid"], z["truth"]), column_errors(z["gmm"], z["truth"])
            es, ep = (column_errors(choose(z, per_stretch=p), z["truth"]) for p in (True, False))
            if max(abs(np.mean(eh <= 5) - np.mean(x <= 5)) for x in (es, ep)) > 0.005:
                print(f"  {side:5s} {key(f):32s} hybrid {np.mean(eh <= 5):6.1%} {met(eh)!s:5s} gmm {np.mean(eg <= 5):6.1%}"
                      f" | select {np.mean(ep <= 5):6.1%} {met(ep)!s:5s} per stretch {np.mean(es <= 5):6.1%} {met(es)}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
