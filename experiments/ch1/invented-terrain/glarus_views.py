"""Dataset views on the Glarus DEM (44 % of its grid made up on load), drawn without and with the invented-terrain
mask: how many cameras stand on invented terrain and how many skylines lie on it over 5 % (2026-12-05).
``python experiments/ch1/invented-terrain/glarus_views.py`` from the repository root."""

import dataclasses

import numpy as np

from skyrender.backend import mitsuba
from skyrender.datasets import synthetic
from skyrender.dem import load_dem
from skyrender.render import Terrain, render_skylines

mitsuba(None)
dem = load_dem("../shared/data/dem/srtm1_glarus_1arc.tif")
sampling = synthetic.Sampling(size=(640, 480), fov_deg=(25.0, 75.0))
for label, grid in (("without the mask", dataclasses.replace(dem, invented=None)), ("with the mask", dem)):
    terrain = Terrain(grid)
    on, shares = 0, []
    for index in range(40):
        pose, intrinsics, _, _ = synthetic.sample_view(terrain, index, 0, sampling)
        skyline, distance = render_skylines(terrain, pose, intrinsics, with_distance=True)
        on += bool(dem.is_invented(pose.x, pose.y))
        shares.append(synthetic.invented_skyline_share(dem, pose, intrinsics, skyline, distance))
    shares = np.array(shares)
    print(f"{label}: cameras on invented terrain {on} of 40; skylines over 5 % invented {int((shares > 0.05).sum())}; "
          f"mean share {shares.mean():.2f}")
