"""The GeoPose3K weisshorn photo's checks in tests/test_features.py (its shadowed snow face, columns 365-405, and hazy
ridge, 550-566: >= 90 % within 5 px) under the four EM budgets, gmm (the default method) and select.

``python experiments/photos/em-budget/shipped/weisshorn_budget.py > experiments/photos/em-budget/shipped/weisshorn.txt``
"""

import os

import cv2
import numpy as np

from skyrender.benchmarks.skyline_photos import column_errors
from skyrender.datasets.real_photos import truth_from_mask
from skyrender.features import SkylineParams, extract_skyline, load_photo

folder = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "..", "..", "shared", "data",
                      "photos", "geopose3k", "weisshorn")
photo = load_photo(os.path.join(folder, "original.png"))
truth = truth_from_mask(cv2.imread(os.path.join(folder, "mask.png"), cv2.IMREAD_GRAYSCALE))
for tol, samples in ((1e-3, 12_000), (1e-2, 6_000), (1e-3, 6_000), (1e-2, 12_000)):
    budget = {"mixture_tol": tol, "mixture_samples": samples}
    e = column_errors(extract_skyline(photo, SkylineParams(**budget)).skyline, truth)
    s = column_errors(extract_skyline(photo, SkylineParams(method="select", **budget)).skyline, truth)
    print(f"tol {tol:g}, {samples} samples: gmm within 5 px: snow face {np.mean(e[365:405] <= 5):.3f}, hazy ridge "
          f"{np.mean(e[550:566] <= 5):.4f}, all columns {np.mean(e <= 5):.3f}; select all columns {np.mean(s <= 5):.3f}")
