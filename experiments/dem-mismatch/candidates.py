"""Where the photo preset loses a rendered view's place: for each view of a dem-mismatch dataset, from its TRUE
skyline (no extractor), the far-horizon poses the photo preset generates, the nearest one's distance to the camera,
the rank of the first within 1 km by the search's cost and by verification score (the preset refines the best 8 by
each), and the scores of the truth itself and of the best pose. No re-ranking: what the search hands on.
``python experiments/dem-mismatch/candidates.py experiments/dem-mismatch/datasets/bigtujunga-block1 16``"""

import sys

import numpy as np

from skyrender.camera import Intrinsics
from skyrender.diagnostics.candidates import far_horizon_candidates, first_rank
from skyrender.experiment import _Localizer, read_dataset
from skyrender.localizer import LocalizeParams
from skyrender.localizer.verification import verify_poses


def main(path: str, n: int) -> None:
    manifest, views = read_dataset(path)
    loc = _Localizer(manifest)
    model, dem, terrain = loc.model_for("photo"), loc.dem, loc.terrain
    params = LocalizeParams.for_photos()
    print(f"{path}: {len(model.horizons)} horizon centres")
    for v in views[:n]:
        sky = np.load(v["paths"]["skyline"])
        W, H = int(v["width"]), int(v["height"])
        k = Intrinsics.from_fov(float(v["fov"]), W, H)
        w = np.ones(W)
        poses, cost, score, _ = far_horizon_candidates(model, dem, terrain, sky, w, k, float(v["height_above_ground"]),
                                                       params)
        truth = np.array([v[c] for c in ("x", "y", "z", "pan", "tilt", "swing")])
        truth_score, _ = verify_poses(terrain, truth[None], k, sky, w, params.verify_stride, params=params.score)
        d = np.hypot(poses[:, 0] - truth[0], poses[:, 1] - truth[1])
        near = d <= 1000
        print(f"view {v['index']}: {len(poses)} poses, nearest {d.min():.0f} m; rank of the first within 1 km by cost "
              f"{first_rank(np.argsort(cost, kind='stable'), d, 1000)} / by score "
              f"{first_rank(np.argsort(score, kind='stable'), d, 1000)}; truth {truth_score[0]:.2f} px, best pose "
              f"{score.min():.2f} px, best within 1 km {score[near].min() if near.any() else np.nan:.2f} px", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 16)
