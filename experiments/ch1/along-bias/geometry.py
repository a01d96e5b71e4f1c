"""Where right answers stand against the truth, along and across the line of sight, and the geometry of their
skyline (a diagnostic on the training side; nothing fitted here).

``python experiments/ch1/along-bias/geometry.py ROWS.json OUT.json`` (from the repository root)

For each row of a ``bench-real`` run (``refined_poses``, ``truth_xy``) whose answer lies within 1 km of the truth: the
answer minus the truth along the answer's pan (+: towards the view) and across it (+: to the right), and, rendered at
the answer's pose, the median distance of the terrain forming its skyline (m) and the median elevation angle of the
skyline above the camera's horizontal (deg), on the photo's 1024 columns.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
from PIL import Image

from skyrender.benchmarks.real_localize import refined_of, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import photo_items
from skyrender.render import render_skylines


def main(rows_path: str, out: str) -> None:
    with open(rows_path) as f:
        data = json.load(f)
    rows = data["rows"] if "rows" in data else data["photos"]
    items = {it.key: it for it in photo_items() if it.lat is not None}
    rows = [r for r in rows if r.get("refined_poses") and r.get("truth_xy")]
    result = []
    for row, it, terrain in with_terrain(rows, items):
        poses = refined_of(row)
        best = poses[int(np.argmin(poses[:, 7]))]
        dx, dy = best[:2] - np.asarray(row["truth_xy"])
        error = float(math.hypot(dx, dy))
        if error > 1000:
            continue
        pan = math.radians(best[3])
        along, across = dx * math.sin(pan) + dy * math.cos(pan), dx * math.cos(pan) - dy * math.sin(pan)
        W0, H0 = Image.open(it.image_path).size
        W = int(row.get("width") or W0)  # the searched width (1,024 columns at most)
        H, f_px = int(round(H0 * W / W0)), float(best[6])
        k = Intrinsics(W, H, f_px, W / 2, H / 2)
        sky, distance = render_skylines(terrain, np.asarray([best[:6]]), k, with_distance=True)
        sky, distance = sky[0], distance[0]
        ok = np.isfinite(sky) & np.isfinite(distance)
        # elevation of each skyline column above the horizontal: the tilt plus the row's angle above the centre
        elevation = best[4] + np.degrees(np.arctan((H / 2 - sky[ok]) / f_px))
        result.append({"photo": row["photo"], "error_m": error, "along_m": float(along), "across_m": float(across),
                       "skyline_distance_m": float(np.median(distance[ok])) if ok.any() else None,
                       "skyline_elevation_deg": float(np.median(elevation)) if ok.any() else None,
                       "tilt": float(best[4]), "confidence": row.get("confidence")})
        print(f"{row['photo']:32s} along {along:7.0f} across {across:7.0f}  skyline {result[-1]['skyline_distance_m']:8.0f} m "
              f"at {result[-1]['skyline_elevation_deg']:5.2f} deg", flush=True)
    with open(out, "w") as f:
        json.dump({"rows": rows_path, "answers": result}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
