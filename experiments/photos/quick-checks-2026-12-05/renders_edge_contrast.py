"""gmm with and without ``SkylineParams.edge_contrast`` (2) on renders of the built-in DEM (a probe, 2026-12-05).

``python experiments/photos/quick-checks-2026-12-05/renders_edge_contrast.py > renders-edge-contrast.txt``: the test
suite's valley camera turned to 5 headings (two facing the valley side, tilted down), each rendered with 7 looks
(clear, haze, foreground occluders, sunset, cloud banks on the ridges, overcast, power lines); median error (px) and
share of columns within 5 px of the true sky boundary, the option off and on.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.camera import Intrinsics
from skyrender.dem import load_dem
from skyrender.features import extract_skyline
from skyrender.features.skyline import SkylineParams
from skyrender.render import Terrain
from skyrender.render.photo import Look, render_photo

LOOKS = {"clear": Look(seed=1), "haze": Look(seed=2, noise=0.01, haze_distance=15_000.0, sun_elevation=12.0),
         "occluders": Look(seed=3, occluders=0.2), "sunset": Look(seed=4, sky="sunset", sun_elevation=3.0, sun_azimuth=40.0),
         "clouds": Look(seed=5, clouds=0.6), "overcast": Look(seed=6, sky="overcast"), "cables": Look(seed=7, power_lines=2)}
VIEWS = ((40, 4), (135, 3), (220, 0), (300, -10), (280, -10))  # (pan, tilt) deg


def main() -> None:
    dem = load_dem("builtin:jacksboro")
    rows, cols = dem.elevation.shape
    middle = dem.elevation[rows // 3: 2 * rows // 3, cols // 3: 2 * cols // 3]
    r, c = np.unravel_index(np.argmin(middle), middle.shape)  # the tests' valley_view camera
    pose = dem.camera_pose(float(dem.x_centres[c + cols // 3]), float(dem.y_centres[r + rows // 3]), 2.0, 40.0, 4.0, 0.0)
    K = Intrinsics.from_fov(60.0, 320, 240)
    terrain = Terrain(dem)
    for pan, tilt in VIEWS:
        for name, look in LOOKS.items():
            photo = render_photo(terrain, dataclasses.replace(pose, pan=float(pan), tilt=float(tilt)), K, look)
            out = []
            for gain in (0.0, 2.0):
                found = extract_skyline(photo.image, SkylineParams(edge_contrast=gain)).skyline
                e = column_errors(found, photo.sky_boundary)
                out.append(f"{np.median(e):6.2f} px {np.mean(e <= 5) * 100:5.1f} %")
            print(f"pan {pan:3d} tilt {tilt:3d} {name:9s} off: {out[0]}   on: {out[1]}", flush=True)


if __name__ == "__main__":
    main()
