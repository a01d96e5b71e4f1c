"""Does the answer win on each part of the skyline, or only on the whole? (a probe on stored poses, 2026-12-05)

``python experiments/ch1/split-half/probe.py OUT.json [ROWS.json]`` (default rows: ``../confidence-train-rows.json``,
the 73 training-side photos, fov known). For each row, the best 4 distinct places among its refined poses (more
than 1 km apart) are rendered once, and each is scored (``score_skylines``, the photo preset's score) on the
skyline's left and right halves and on its thirds (the weights of the other columns set to 0). The answer's part
margins: 1 - its score / the best other place's score, on each part; the probe reports the smallest of them.
A look-alike that wins the whole skyline by fitting one part very well while the right place fits another better
would have a small or negative part margin where a right answer's is positive everywhere.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from skyrender.benchmarks.real_localize import photo_skyline, refined_of, with_terrain
from skyrender.camera import Intrinsics
from skyrender.datasets.real_photos import REPO, items_on_side
from skyrender.localizer import LocalizeParams
from skyrender.localizer.confidence import distinct_places
from skyrender.localizer.verification import score_skylines
from skyrender.render import render_skylines

ROWS = os.path.join(REPO, "experiments", "ch1", "confidence-train-rows.json")


def part_margins(scores: np.ndarray) -> np.ndarray:
    """(parts,) 1 - answer / best other, for scores (places, parts) with the answer in row 0."""
    return 1.0 - scores[0] / np.maximum(scores[1:].min(axis=0), 1e-9)


def main(out: str, rows_path: str = ROWS) -> None:
    params = LocalizeParams.for_photos()
    rows = json.load(open(rows_path))["rows"]
    items = {it.key: it for side in ("train", "dev", "validation") for it in items_on_side(side)
             if it.key.startswith("ch1/")}
    result = []
    for row, it, terrain in with_terrain([r for r in rows if r["photo"] in items], items):
        image, sky, weights = photo_skyline(it, params)
        H, W = image.shape[:2]
        poses = refined_of(row)
        places = distinct_places(poses, 4)
        if len(places) < 2:
            continue
        P = poses[places]
        k = np.column_stack([P[:, 6], np.full(len(P), W / 2), np.full(len(P), H / 2)])
        rendered = render_skylines(terrain, P[:, :6], Intrinsics(W, H, P[0, 6], W / 2, H / 2), per_pose_intrinsics=k)
        columns = np.arange(W)
        parts = {"halves": [columns < W / 2, columns >= W / 2],
                 "thirds": [columns < W / 3, (columns >= W / 3) & (columns < 2 * W / 3), columns >= 2 * W / 3]}
        record = {"photo": it.key, "error_m": float(np.hypot(*(P[0, :2] - np.asarray(row["truth_xy"])))),
                  "margin": float(1 - P[0, 7] / P[1:, 7].min()),
                  "whole": float(part_margins(score_skylines(rendered, sky, weights, params.score)[0][:, None])[0])}
        for name, masks in parts.items():
            s = np.column_stack([score_skylines(rendered, sky, weights * m, params.score)[0] for m in masks])
            record[name] = part_margins(s).tolist()
        result.append(record)
        print(f"{it.key:34s} {record['error_m']:8.0f} m  margin {record['margin']:.3f} (rendered {record['whole']:.3f})"
              f"  halves {np.round(record['halves'], 3)}  thirds {np.round(record['thirds'], 3)}", flush=True)
    with open(out, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main(*sys.argv[1:])
