"""Is lens distortion part of the oracle's residual? (a probe, 2026-12-05)

``python experiments/ch1/distortion/oracle_k1.py SIDE N OUT.json``

For N CH1 photos of a side (spread over its places): the oracle fit at the true position
(``skyrender.diagnostics.oracle.oracle_fit``: pan, tilt, swing, height +-50 m, focal +-5 %), then the
same refined once more with one radial term k: the photo's true skyline is undistorted as
x_u = x_d (1 + k r_d^2) (normalised image coordinates about the centre) before it is compared.
Reported: the robust residual (mean of |residual| capped at 20 px), median and 75th percentile
without and with k, and the k fitted.
"""

from __future__ import annotations

import json
import sys

import numpy as np
from scipy.optimize import minimize

from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import items_on_side
from skyrender.diagnostics.oracle import dem_around, oracle_fit, robust_residual
from skyrender.features import load_photo
from skyrender.render import Terrain, render_skylines


def undistort(skyline: np.ndarray, k: float, f: float, cx: float, cy: float) -> np.ndarray:
    """(W,) the skyline of the same photo without radial distortion x_u = x_d (1 + k r_d^2), resampled
    at the column centres; NaN where no undistorted point lands between two with terrain."""
    W = len(skyline)
    u = np.arange(W) + 0.5
    ok = np.isfinite(skyline)
    xd, yd = (u - cx) / f, (np.where(ok, skyline, cy) - cy) / f
    s = 1.0 + k * (xd * xd + yd * yd)
    uu, vu = cx + f * xd * s, cy + f * yd * s
    out = np.interp(u, uu, vu, left=np.nan, right=np.nan)
    has = np.interp(u, uu, ok.astype(float), left=0.0, right=0.0) > 0.999
    return np.where(has, out, np.nan)


def main(side: str, n: int, out: str) -> None:
    items = [it for it in items_on_side(side) if it.key.startswith("ch1/")]
    items = items[:: max(1, len(items) // n)][:n]
    rows = []
    for it in items:
        image = load_photo(it.image_path)
        H, W = image.shape[:2]
        dem = dem_around(it.lat, it.lon, 40.0)
        terrain = Terrain(dem)
        x, y = (float(v) for v in dem.from_lonlat(it.lon, it.lat))
        truth = it.truth_skyline()
        K = Intrinsics(W, H, it.focal_px, W / 2, H / 2)
        fit = oracle_fit(terrain, x, y, truth, K)
        p0 = fit.pose
        f0 = W / (2 * np.tan(np.radians(fit.fov) / 2))

        def loss(p):
            pan, tilt, swing, dz, k = p
            if abs(k) > 0.5:
                return 1e3
            pose = np.array([p0.x, p0.y, p0.z + dz, pan, tilt, swing])
            rendered = render_skylines(terrain, pose, Intrinsics(W, H, f0, W / 2, H / 2))
            return float(robust_residual(rendered, undistort(truth, k, f0, W / 2, H / 2)))

        start = np.array([p0.pan, p0.tilt, p0.swing, 0.0, 0.0])
        best = minimize(loss, start, method="Nelder-Mead",
                        options={"initial_simplex": np.r_[[start], start + np.diag([0.5, 0.5, 1.0, 10.0, 0.1])],
                                 "maxfev": 300, "xatol": 0.005, "fatol": 0.002})
        plain = float(robust_residual(render_skylines(terrain, p0, Intrinsics(W, H, f0, W / 2, H / 2)), truth))
        row = {"photo": it.key, "fov": fit.fov, "residual": plain, "residual_k": float(best.fun),
               "k": float(best.x[4]), "median_px": float(np.nanmedian(np.abs(fit.residual)))}
        rows.append(row)
        print(f"{it.key}: fov {fit.fov:.1f}, residual {plain:.2f} -> {best.fun:.2f} px with k {best.x[4]:+.3f}",
              flush=True)
    json.dump(rows, open(out, "w"), indent=1)
    r = np.array([[x["residual"], x["residual_k"], x["k"]] for x in rows])
    print(f"{len(rows)} photos: residual median {np.median(r[:, 0]):.2f} -> {np.median(r[:, 1]):.2f} px; "
          f"k median {np.median(r[:, 2]):+.3f} (quartiles {np.percentile(r[:, 2], 25):+.3f} {np.percentile(r[:, 2], 75):+.3f})")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
