"""Two models of one DEM (built before and after a change of the far horizons): each one's horizons
against an independent march over the DEM, on random (centre, bin) pairs whose ray stays on the DEM
for 60 km.

``python experiments/scale/one-column-horizons/against_march.py BEFORE_MODEL AFTER_MODEL``"""

import sys

import numpy as np

from skyrender.camera import earth_drop
from skyrender.model import load_model


def main(before: str, after: str, pairs: int = 3000) -> None:
    a = load_model(before).horizons
    model = load_model(after)
    b, dem = model.horizons, model.dem
    assert np.allclose(a.centres, b.centres)
    d = np.abs(b.elevation.astype(np.float64) - a.elevation)
    print(f"{len(a)} centres x {a.elevation.shape[1]} bins; |after - before| median {np.median(d):.3f} deg, "
          f"90th pct {np.percentile(d, 90):.3f}, 99th {np.percentile(d, 99):.3f}")
    rng = np.random.default_rng(0)
    dist = np.arange(1000.0, 60_000.0, 10.0)  # the models' 1 km near clip
    err = {"before": [], "after": []}
    for c, j in zip(rng.integers(0, len(a), pairs), rng.integers(0, a.elevation.shape[1], pairs)):
        x0, y0, z0 = a.centres[c]
        az = np.radians(j * a.bin_deg)
        g = dem.ground(x0 + dist * np.sin(az), y0 + dist * np.cos(az))
        if np.isnan(g).any():
            continue
        march = np.max(np.degrees(np.arctan2(g - earth_drop(dist, True) - z0, dist)))
        err["before"].append(abs(a.elevation[c, j] - march))
        err["after"].append(abs(b.elevation[c, j] - march))
    print(f"{len(err['before'])} pairs with the ray on the DEM for 60 km; |horizon - march| (deg):")
    for name, e in err.items():
        print(f"  {name}: median {np.median(e):.3f}, 90th pct {np.percentile(e, 90):.3f}, "
              f"99th {np.percentile(e, 99):.3f}, max {np.max(e):.2f}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
