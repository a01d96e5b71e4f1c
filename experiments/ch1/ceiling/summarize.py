"""How many CH1 photos can a skyline-fit localizer on SRTM3 get right at all? A table from
``skyrender.diagnostics.truth_refine`` runs (its JSONs), per side and skyline source.

    python experiments/ch1/ceiling/summarize.py RUN.json [RUN.json ...] > experiments/ch1/ceiling/summary.txt

A photo is *lost by the score* when the best fit found at its TRUE position (orientation, then the
photo preset's refinement from there) scores no better than the wrong answer: no search, however
thorough, would make the right place win with this score on this DEM. *Lost by the search*: the
truth fits better, so a candidate near it, refined, would have won. The ceiling of the search is
(right + lost by the search) / photos.
"""

import json
import sys

import numpy as np

from skyrender.datasets.real_photos import split_places
from skyrender.diagnostics.truth_refine import truth_score


def main(paths: list[str]) -> None:
    place_of = split_places()
    print("side        skyline    photos  right  lost by search  lost by score  ceiling of the search"
          "  median truth/answer score ratio, lost by score")
    per_photo = []
    for path in paths:
        run = json.load(open(path))
        rows = run["photos"]
        source = "true" if run.get("true_skyline") else "extracted"
        n = len(rows)
        v = [r["verdict"] for r in rows]
        right, search, score = v.count("right"), v.count("search"), v.count("score")
        ratio = [truth_score(r) / r["answer_score"] for r in rows if r["verdict"] == "score"]
        print(f"{run['side']:11s} {source:10s} {n:6d} {right:6d} {search:15d} {score:14d}"
              f"  {right + search:3d} ({100 * (right + search) / n:.0f} %)          "
              f"  {np.median(ratio) if ratio else float('nan'):.2f}")
        for r in rows:
            per_photo.append((run["side"], source, r["photo"], place_of.get(r["photo"], "?"), r["verdict"],
                              r["error_m"], r["answer_score"], truth_score(r)))
    print("\nper photo: side, skyline, photo, place, verdict, answer's error (m), answer's score, truth's best fit (px)")
    for side, source, photo, place, verdict, err, a, t in per_photo:
        print(f"{side:10s} {source:9s} {photo:34s} {place:8s} {verdict:6s} {err:9.0f} {a:6.2f} {t:6.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
