"""The default ``select`` extractor of this session's code against the committed benchmark, photo by photo.

``python experiments/photos/check-2026-12-05-session9/select_unchanged.py``

``../select-gate/compare.json`` holds, for every validation and held-out photo, the default ``select``
(``select_gmm_above`` = 0) extracted with this session's code; ``../bench-skyline.json`` the same photos with the
code before it (commit 8c23491). Each photo's median error and share of columns within 5 px are compared.
"""

from __future__ import annotations

import json
import os

from skyrender.benchmarks.skyline_photos import unchanged_report
from skyrender.datasets.real_photos import REPO

HERE = os.path.join(REPO, "experiments", "photos")


def main() -> None:
    now = {r["photo"]: r["always"] for r in json.load(open(os.path.join(HERE, "select-gate", "compare.json")))}
    bench = json.load(open(os.path.join(HERE, "bench-skyline.json")))
    print(unchanged_report(now, bench))


if __name__ == "__main__":
    main()
