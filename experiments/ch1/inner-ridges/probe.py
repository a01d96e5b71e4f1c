"""Inner ridges as a second cue: do the photo's edges follow the answer's occluding contours? (a probe, 2026-12-05)

``python experiments/ch1/inner-ridges/probe.py OUT.json [--places 4] [--width 256]``

Below the skyline a mountain photo shows more ridges, each the occluding contour of nearer terrain against farther
terrain; the skyline score uses none of them. For each of the 73 training-side rows (``../confidence-train-rows.json``),
the best ``--places`` distinct refined places (> 1 km apart) are ray-cast at ``--width`` px wide
(``cast_pixel_rays``); their occluding contours are the pixel pairs where the distance jumps by more than 1.5x going
up, both on terrain and more than 3 px below the skyline. The photo at the same size gives horizontal edges (vertical
Sobel magnitude over its 85th percentile below the extracted skyline, dilated by 1 px). The support of a place is the
share of its contour pixels on a photo edge minus the share of the photo's terrain pixels that are edges (chance).
Reported: whether the right place (when among the places) has the highest support, and the support of right and wrong
answers.
"""

from __future__ import annotations

import argparse
import json
import os

import cv2
import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, refined_of, with_terrain
from skyrender.camera import Intrinsics, Pose
from skyrender.datasets.real_photos import REPO, items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.confidence import distinct_places
from skyrender.render.photo import cast_pixel_rays

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def photo_edges(image: np.ndarray, skyline: np.ndarray, w: int) -> tuple[np.ndarray, np.ndarray]:
    """(edges, terrain) bool (h, w) at width w: horizontal edges below the skyline, and the terrain mask."""
    H, W = image.shape[:2]
    h = int(round(H * w / W))
    grey = cv2.cvtColor(cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA), cv2.COLOR_RGB2GRAY).astype(np.float32)
    gy = np.abs(cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3))
    sky_v = np.interp((np.arange(w) + 0.5) * W / w - 0.5, np.arange(W), np.nan_to_num(skyline, nan=H)) * h / H
    terrain = np.arange(h)[:, None] > sky_v[None, :] + 3
    if not terrain.any():
        return np.zeros((h, w), bool), terrain
    edges = (gy > np.percentile(gy[terrain], 85)) & terrain
    return cv2.dilate(edges.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool), terrain


def contours(t: np.ndarray, ratio: float = 1.5, min_m: float = 0.0) -> np.ndarray:
    """(h, w) bool: pixel v where the terrain distance of the pixel above is > ratio x its own (an occluding ridge),
    the ridge itself at least ``min_m`` away."""
    out = np.zeros(t.shape, bool)
    above, below = t[:-1], t[1:]
    ok = np.isfinite(above) & np.isfinite(below)
    out[1:] = ok & (above > ratio * below) & (below >= min_m)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--places", type=int, default=4)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--ratio", type=float, default=1.5)
    ap.add_argument("--min-km", type=float, default=0.0, help="only contours of ridges this far or farther")
    ap.add_argument("--rows", default=ROWS, help="a real_localize run's JSON instead (its fov-known rows): a report")
    a = ap.parse_args()
    doc = json.load(open(a.rows))
    rows = [r for r in doc.get("rows", doc.get("photos", [])) if r.get("fov_mode", "known") == "known"]
    items = {it.key: it for side in ("train", "dev", "validation") for it in items_on_side(side) if it.key.startswith("ch1/")}
    params = LocalizeParams.for_photos()
    out = []
    for row, it, terrain in with_terrain(rows, items):
        image, sky, _ = photo_skyline(it, params)
        H, W = image.shape[:2]
        edges, terrain_px = photo_edges(image, sky, a.width)
        chance = float(edges[terrain_px].mean()) if terrain_px.any() else 0.0
        h = edges.shape[0]
        poses = refined_of(row)
        truth = np.asarray(row["truth_xy"])
        rec = {"photo": it.key, "chance": chance, "error_m": row.get("error_m", row.get("withheld_error_m")),
               "confidence": row["confidence"], "places": []}
        for i in distinct_places(poses, a.places):
            s = a.width / W
            K = Intrinsics(a.width, h, poses[i, 6] * s, a.width / 2, h / 2)
            t, *_ = cast_pixel_rays(terrain, Pose.from_array(poses[i, :6]), K)
            c = contours(t, a.ratio, a.min_km * 1000.0) & terrain_px
            support = float(edges[c].mean()) - chance if c.sum() >= 20 else float("nan")
            rec["places"].append({"dist_m": float(np.hypot(*(poses[i, :2] - truth))), "score": float(poses[i, 7]),
                                  "contour_px": int(c.sum()), "support": support})
        out.append(rec)
        print(it.key, f"chance {chance:.2f}", " | ".join(f"{p['dist_m'] / 1000:.1f} km {p['score']:.2f} px "
                                                        f"support {p['support']:+.2f} ({p['contour_px']})"
                                                        for p in rec["places"]), flush=True)
    json.dump(out, open(a.out, "w"), indent=1)
    right_best, with_right, sup_right, sup_wrong = 0, 0, [], []
    for rec in out:
        places = rec["places"]
        sup = np.array([p["support"] for p in places])
        near = np.array([p["dist_m"] <= 1000 for p in places])
        (sup_right if near[0] else sup_wrong).append(sup[0])
        if near.any() and np.isfinite(sup).any():
            with_right += 1
            right_best += bool(near[int(np.nanargmax(sup))])
    print(f"right place among the {a.places}: {with_right} photos; it has the highest support on {right_best}")
    print(f"support of the answer: right {np.nanmedian(sup_right):+.3f} (n {len(sup_right)}), "
          f"wrong {np.nanmedian(sup_wrong):+.3f} (n {len(sup_wrong)})")


if __name__ == "__main__":
    main()
