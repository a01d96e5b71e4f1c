"""Could the fov-unknown mode ask a second opinion too? (a probe on the training side)

``python experiments/ch1/fov-unknown-second/probe.py OUT.json`` (from the repository root)

With the fov given, an answer about to be withheld asks a search with the fov unknown, and where both end at one place
it is given (``pipeline._second_opinion``). With the fov unknown there is no given fov to search with, but the answer
brings one: the focal length it was refined to. For every training-side photo the fov-unknown mode answered with a
confidence of 0.3–0.95 (withheld; the shipped rows of the Makefile's ``fit-photo-confidence``), the photo is localized
again with the fov given as the answer's own (the photo preset, no abstention, no second opinion), and that search's
best place is compared with the answer: within 1 km is agreement. Does agreement tell right answers from wrong?
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import replace

import numpy as np

from skyrender.benchmarks.real_localize import answer_xy, refined_of, run
from skyrender.camera import horizontal_fov
from skyrender.datasets.real_photos import photo_items
from skyrender.localizer import LocalizeParams

ROWS = ("experiments/ch1/rerank-cut-fov-unknown/bench-real-train-cut300.json",
        "experiments/ch1/rerank-cut-fov-unknown/bench-real-dev-cut300.json",
        "experiments/ch1/mode-agreement/bench-real-train-rest32.json")
BAND = (0.3, 0.95)


def main(out: str) -> None:
    rows = {}
    for path in ROWS:
        with open(path) as f:
            for r in json.load(f)["photos"]:
                if r["fov_mode"] == "unknown" and BAND[0] <= r["confidence"] < BAND[1]:
                    rows[r["photo"]] = r
    items = {it.key: it for it in photo_items() if it.key in rows}
    asked = []
    for key, r in rows.items():
        poses = refined_of(r)
        best = poses[int(np.argmin(poses[:, 7]))]
        assert r["width"] == 1024  # the CH1 photos are searched at their own width: f_px is the photo's
        asked.append(replace(items[key], focal_px=float(best[6])))
    asked.sort(key=lambda it: it.key)
    params = LocalizeParams.from_dict({"min_confidence": 0.0, "second_opinion_from": math.inf},
                                      LocalizeParams.for_photos())
    again = {r["photo"]: r for r in run(asked, ["known"], params=params)}
    result = []
    for key, r in sorted(rows.items()):
        xy, truth = answer_xy(r), np.asarray(r["truth_xy"])
        second = answer_xy(again[key])
        poses = refined_of(r)
        f_answer = poses[int(np.argmin(poses[:, 7])), 6]
        row = {"photo": key, "confidence": r["confidence"], "error_m": float(np.hypot(*(xy - truth))),
               "answer_fov": horizontal_fov(1024, f_answer), "true_fov": horizontal_fov(1024, items[key].focal_px),
               "second_error_m": float(np.hypot(*(second - truth))), "apart_m": float(np.hypot(*(second - xy)))}
        row["agree"] = row["apart_m"] <= 1000.0
        result.append(row)
        print(f"{key:32s} conf {row['confidence']:.2f} answer {row['error_m']:7.0f} m at {row['answer_fov']:5.1f} deg; "
              f"the second search {row['second_error_m']:7.0f} m, {row['apart_m']:7.0f} m apart: "
              f"{'agrees' if row['agree'] else 'does not'}", flush=True)
    right = np.array([x["error_m"] <= 1000 for x in result])
    agree = np.array([x["agree"] for x in result])
    print(f"right answers agreeing: {int((right & agree).sum())} of {int(right.sum())}; "
          f"wrong answers agreeing: {int((~right & agree).sum())} of {int((~right).sum())}")
    with open(out, "w") as f:
        json.dump({"rows": list(ROWS), "band": BAND, "photos": result}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
