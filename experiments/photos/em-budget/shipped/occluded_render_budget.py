"""tests/test_localizer.py::test_localizes_with_a_fifth_of_the_columns_occluded under the four EM budgets: the render
preset's gmm line extracted with each (``SkylineParams.mixture_tol`` / ``mixture_samples``) and handed to ``localize``.

``python experiments/photos/em-budget/shipped/occluded_render_budget.py``
``  > experiments/photos/em-budget/shipped/occluded-render.txt``
"""

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "..", "tests"))
from conftest import K, photo_of  # noqa: E402

from skyrender.benchmarks.views import sample_views  # noqa: E402
from skyrender.dem.synthetic import fractal_terrain  # noqa: E402
from skyrender.features import SkylineParams, extract_skyline  # noqa: E402
from skyrender.localizer import localize  # noqa: E402
from skyrender.model import build_model  # noqa: E402
from skyrender.render import Terrain  # noqa: E402

dem = fractal_terrain()
terrain = Terrain(dem)
model = build_model(dem, terrain=terrain)
pose = sample_views(terrain, model, K, 5, seed=1).poses[2]
image = photo_of(terrain, pose, occluders=0.2, seed=2)
clean = extract_skyline(photo_of(terrain, pose)).skyline
for tol, samples in ((1e-3, 12_000), (1e-2, 6_000), (1e-3, 6_000), (1e-2, 12_000)):
    found = extract_skyline(image, SkylineParams(mixture_tol=tol, mixture_samples=samples))
    start = time.perf_counter()
    r = localize(image, model, 2.0, 60.0, terrain=terrain, skyline=found)
    err = np.hypot(*(r.pose[:2] - pose.array()[:2])) if r.localized else float("nan")
    d = np.abs(found.skyline - clean)
    print(f"tol {tol:g}, {samples} samples: the line against the unoccluded render's: median {np.nanmedian(d):.2f} px, "
          f"within 5 px {np.mean(d <= 5):.3f}; localized {r.localized}, confidence {r.confidence:.3f}, error {err:.1f} m, "
          f"{r.hypotheses} hypotheses, {time.perf_counter() - start:.1f} s", flush=True)
