"""The default ``select`` extractor of session 10's code against the committed benchmark, photo by photo.

``python experiments/photos/check-2026-12-05-session10/select_unchanged.py``: every validation and held-out photo
extracted with this code's default ``select`` (``SkylineParams.edge_contrast`` 0, ``select_gmm_above`` 0), each
photo's median error and share of columns within 5 px compared with ``../bench-skyline.json`` (the code before it).
"""

from __future__ import annotations

import json
import os

from skyrender.benchmarks.skyline_photos import evaluate
from skyrender.datasets.real_photos import REPO, items_on_side

HERE = os.path.join(REPO, "experiments", "photos")


def main() -> None:
    bench = json.load(open(os.path.join(HERE, "bench-skyline.json")))
    same, differ = 0, []
    for side in ("validation", "heldout"):
        now = {r["photo"]: r["select"] for r in evaluate(items_on_side(side), ["select"], progress=False)}
        for p in bench["sides"][side]["photos"]:
            a, b = p["select"], now[p["photo"]]
            if a["median"] == b["median"] and a["within5"] == b["within5"]:
                same += 1
            else:
                differ.append((p["photo"], a, b))
    print(f"bench-skyline.json at {bench['commit']}: {same} of {same + len(differ)} photos with the same median and "
          f"share within 5 px")
    for photo, a, b in differ:
        print(f"  {photo}: {a} -> {b}")


if __name__ == "__main__":
    main()
