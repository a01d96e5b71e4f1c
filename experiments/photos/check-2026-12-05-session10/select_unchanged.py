"""The default ``select`` extractor of session 10's code against the committed benchmark, photo by photo.

``python experiments/photos/check-2026-12-05-session10/select_unchanged.py``: every validation and held-out photo
extracted with this code's default ``select`` (``SkylineParams.edge_contrast`` 0, ``select_gmm_above`` 0), each
photo's median error and share of columns within 5 px compared with ``../bench-skyline.json`` (the code before it).
"""

from __future__ import annotations

import json
import os

from skyrender.benchmarks.skyline_photos import evaluate, unchanged_report
from skyrender.datasets.real_photos import REPO, items_on_side

HERE = os.path.join(REPO, "experiments", "photos")


def main() -> None:
    bench = json.load(open(os.path.join(HERE, "bench-skyline.json")))
    now = {r["photo"]: r["select"] for side in ("validation", "heldout")
           for r in evaluate(items_on_side(side), ["select"], progress=False)}
    print(unchanged_report(now, bench))


if __name__ == "__main__":
    main()
