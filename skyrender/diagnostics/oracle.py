"""The oracle fit: how well can the DEM explain a real photo's skyline at the TRUE position?

``python -m skyrender.diagnostics.oracle [--side train] [--limit N] [--out experiments/ch1]``

For each CH1 photo (true position and focal length known, heading unknown): render
skylines from the true position over a grid of pan (2 deg), tilt (2 deg) and swing,
keep the best, then refine pan, tilt, swing, the camera height (2 m above ground,
free within +-50 m) and the focal length (+-5 %) by Nelder-Mead on a robust residual
(mean of |residual| capped at 20 px). Reported: the residual per column (rendered
minus the photo's true skyline, px) summarised as median / 75th percentile, and by
the distance of the terrain forming the rendered skyline (< 1, 1-3, 3-10, 10-30,
>= 30 km). No localizer can fit the photo better than this at the right place, so it
is the floor every acceptance threshold must clear.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass

import numpy as np

from ..camera import Intrinsics, Pose
from ..datasets.real_photos import DEFAULT_PHOTOS, REPO, PhotoItem, items_on_side

DEM_DIR = os.path.normpath(os.path.join(DEFAULT_PHOTOS, "..", "dem"))
DISTANCE_BINS_KM = (0.0, 1.0, 3.0, 10.0, 30.0, np.inf)
RESIDUAL_CAP_PX = 20.0


@dataclass(frozen=True)
class OracleFit:
    """The best pose at the true position and its per-column residuals and distances."""

    pose: Pose
    height: float  # m above ground
    fov: float
    residual: np.ndarray  # (W,) rendered - true skyline, px (NaN where either is missing)
    distance: np.ndarray  # (W,) m to the terrain forming the rendered skyline
    seconds: float


def tiles_around(lat: float, lon: float, dem_dir: str = DEM_DIR) -> list[str]:
    """The SRTM .hgt tiles of ``dem_dir`` holding (lat, lon) and its eight neighbours."""
    la, lo = int(np.floor(lat)), int(np.floor(lon))
    names = [f"{'N' if a >= 0 else 'S'}{abs(a):02d}{'E' if b >= 0 else 'W'}{abs(b):03d}.hgt"
             for a in (la - 1, la, la + 1) for b in (lo - 1, lo, lo + 1)]
    return [os.path.join(dem_dir, n) for n in names if os.path.exists(os.path.join(dem_dir, n))]


def dem_around(lat: float, lon: float, radius_km: float = 60.0, dem_dir: str = DEM_DIR):
    """The DEM (mosaic of the tiles around) within ``radius_km`` of (lat, lon)."""
    from ..dem import load_dem

    dlat = radius_km / 110.57
    dlon = radius_km / (111.32 * np.cos(np.radians(lat)))
    return load_dem(tiles_around(lat, lon, dem_dir), bounds=(lon - dlon, lat - dlat, lon + dlon, lat + dlat))


def robust_residual(rendered: np.ndarray, truth: np.ndarray, cap: float = RESIDUAL_CAP_PX) -> np.ndarray:
    """(..., ) mean over columns with truth of min(|rendered - truth|, cap); a rendered NaN
    (sky only) against truth counts as the cap."""
    has = np.isfinite(truth)
    r = np.abs(rendered[..., has] - truth[has])
    return np.mean(np.where(np.isfinite(r), np.minimum(r, cap), cap), axis=-1)


def oracle_fit(terrain, x: float, y: float, truth: np.ndarray, intrinsics: Intrinsics, *, height: float = 2.0,
               height_range: float = 50.0, focal_range: float = 0.05) -> OracleFit:
    """The oracle fit of one photo skyline ``truth`` (W,) at world (x, y); see the module doc."""
    from scipy.optimize import minimize

    from ..render import render_skylines

    t0 = time.perf_counter()
    dem = terrain.dem
    ground = float(dem.ground(x, y))
    W, H = intrinsics.width, intrinsics.height
    # coarse: a quarter of the resolution, pan x tilt x swing grid
    q = 4
    small = Intrinsics(W // q, H // q, intrinsics.f_px / q, intrinsics.cx / q, intrinsics.cy / q)
    truth_small = truth[q // 2 :: q][: W // q] / q
    pans, tilts, swings = np.arange(0, 360, 2.0), np.arange(-20, 42, 2.0), np.array([-4.0, 0.0, 4.0])
    P, T, S = np.meshgrid(pans, tilts, swings, indexing="ij")
    poses = np.column_stack([np.full(P.size, x), np.full(P.size, y), np.full(P.size, ground + height),
                             P.ravel(), T.ravel(), S.ravel()])
    score = robust_residual(render_skylines(terrain, poses, small, subpixel=False), truth_small, RESIDUAL_CAP_PX / q)
    best = poses[np.argsort(score)[:6]]

    def loss(p):
        pan, tilt, swing, dh, df = p
        if abs(dh) > height_range or abs(df) > focal_range:
            return 1e3
        pose = np.array([x, y, ground + height + dh, pan, tilt, swing])
        k = np.array([[intrinsics.f_px * (1 + df), intrinsics.cx, intrinsics.cy]])
        return float(robust_residual(render_skylines(terrain, pose, intrinsics, per_pose_intrinsics=k), truth))

    fits = [minimize(loss, np.r_[b[3:6], 0.0, 0.0], method="Nelder-Mead",
                     options={"initial_simplex": np.r_[[np.r_[b[3:6], 0.0, 0.0]],
                                                         np.r_[b[3:6], 0.0, 0.0] + np.diag([1.0, 1.0, 2.0, 20.0, 0.02])],
                              "maxfev": 250, "xatol": 0.01, "fatol": 0.005}) for b in best]
    pan, tilt, swing, dh, df = min(fits, key=lambda r: r.fun).x
    pose = Pose(x, y, ground + height + dh, pan % 360.0, tilt, swing)
    k = Intrinsics(W, H, intrinsics.f_px * (1 + df), intrinsics.cx, intrinsics.cy)
    rendered, distance = render_skylines(terrain, pose, k, with_distance=True)
    return OracleFit(pose, height + dh, k.fov, rendered - truth, distance, time.perf_counter() - t0)


def summarise(fit: OracleFit) -> dict:
    r, d = np.abs(fit.residual), fit.distance
    ok = np.isfinite(r)
    out = {"median_px": float(np.median(r[ok])) if ok.any() else None,
           "p75_px": float(np.percentile(r[ok], 75)) if ok.any() else None,
           "within5": float(np.mean(r[ok] <= 5)) if ok.any() else 0.0, "pan": fit.pose.pan, "tilt": fit.pose.tilt,
           "swing": fit.pose.swing, "height": fit.height, "fov": fit.fov, "seconds": fit.seconds, "by_distance": {}}
    for lo, hi in zip(DISTANCE_BINS_KM[:-1], DISTANCE_BINS_KM[1:]):
        sel = ok & (d >= lo * 1000) & (d < hi * 1000)
        if sel.any():
            out["by_distance"][f"{lo:g}-{hi:g} km"] = {"columns": int(sel.sum()), "median_px": float(np.median(r[sel]))}
    return out


def oracle_for_photo(item: PhotoItem, radius_km: float = 60.0) -> dict:
    """Load the DEM around a CH1 photo, fit, summarise."""
    from ..features import load_photo
    from ..render import Terrain

    image = load_photo(item.image_path)
    H, W = image.shape[:2]
    dem = dem_around(item.lat, item.lon, radius_km)
    x, y = (float(v) for v in dem.from_lonlat(item.lon, item.lat))
    fit = oracle_fit(Terrain(dem), x, y, item.truth_skyline(), Intrinsics(W, H, item.focal_px, W / 2, H / 2))
    return {"photo": item.key, **summarise(fit)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", default="train", choices=["train", "dev", "validation"])
    parser.add_argument("--limit", type=int, default=0)
    parser.add_argument("--radius-km", type=float, default=60.0)
    parser.add_argument("--out", default=os.path.join(REPO, "experiments", "ch1"))
    args = parser.parse_args(argv)
    items = [it for it in items_on_side(args.side) if it.key.startswith("ch1/")]
    if args.limit:
        items = items[:: max(1, len(items) // args.limit)][: args.limit]
    rows = []
    for it in items:
        row = oracle_for_photo(it, args.radius_km)
        rows.append(row)
        bins = "  ".join(f"{k}: {v['median_px']:.1f} px ({v['columns']})" for k, v in row["by_distance"].items())
        print(f"{row['photo']:36s} median {row['median_px']:6.2f} px, p75 {row['p75_px']:6.2f}, within 5 px "
              f"{100 * row['within5']:5.1f} %, tilt {row['tilt']:5.1f}, height {row['height']:5.1f} m, fov "
              f"{row['fov']:5.2f}, {row['seconds']:4.1f} s | {bins}", flush=True)
    med = np.array([r["median_px"] for r in rows])
    print(f"{len(rows)} photos: oracle median residual, median over photos {np.median(med):.2f} px, "
          f"75th pct {np.percentile(med, 75):.2f} px, max {med.max():.2f} px")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, f"oracle-{args.side}.json"), "w") as f:
        json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
