"""Fit the boundary search and the column confidence of the learned extractor.

``python -m skyrender.training.skyline_fit`` (``make train-sky-net`` runs it after the
network) — on the *dev* photos of the fixed split only (training places and Web photos
the network was not trained on; never the validation side):

1. the dynamic programme's weights with the network's probability (edge bonus, jump
   cost, jump cap) by grid search, maximising the mean share of columns within 5 px;
2. the per-column confidence: a logistic regression of "within 5 px of the truth" on
   :func:`skyrender.features.skyline.confidence_features`, written to
   ``skyrender/features/weights/sky_net_fit.json`` (read by the extractor).

The fit must see the network's output on photos it was not trained on: every dev photo goes
through one network (``--weights``, default the shipped one, which never saw dev), or, for a
network trained on the dev photos too (cross-fitting, ``sky_net --dev-fold 0 1``), the weights
are fitted on out-of-fold output (``--held-out-weights PATTERN``: ``PATTERN.format(k)`` is a
network trained like it but without dev fold k, :func:`~skyrender.datasets.real_photos.dev_fold_of`;
each dev photo is run through the one that never saw it).
``make bench-skyline`` measures the result on the validation side.
"""

from __future__ import annotations

import argparse
import itertools
import json

import numpy as np

from ..benchmarks.skyline_photos import column_errors
from ..datasets.real_photos import dev_fold_of, items_on_side
from ..features.sky import pixel_features
from ..features.sky_net import NET_WIDTH
from ..features.skyline import (
    _boundary,
    _edge_strength,
    _subpixel,
    boundary_skyline,
    confidence_features,
    fitted_path,
    net_probability,
)

EDGE_BONUS = (16.0, 32.0, 64.0, 128.0)
JUMP_COST = (0.5, 1.0, 2.0, 4.0)
JUMP_CAP = (24.0, 48.0, 96.0)


def prepared(photos: int, weights: str | None = None, net_width: int = NET_WIDTH, held_out_weights: str | None = None):
    """(features, colour edges, P(sky), truth) of up to ``photos`` dev photos, evenly spread;
    the network (``weights``; or per photo ``held_out_weights.format(fold)``, the one that did
    not train on its dev fold) run ``net_width`` px wide."""
    from ..features.photo_io import load_photo

    fold = dev_fold_of() if held_out_weights else {}
    items = items_on_side("dev")
    step = max(1, len(items) // photos) if photos else 1
    out = []
    for it in items[::step]:
        image = load_photo(it.image_path)
        features = pixel_features(image)
        net = held_out_weights.format(fold[it.key]) if held_out_weights else weights
        out.append((features, _edge_strength(features, 97.0), net_probability(image, net, net_width), it.truth_skyline()))
    return out


def skyline_with(features, edges, p, edge: float, cost: float, cap: float):
    """(skyline, rows, contrast) of one photo for one set of the search's weights."""
    rows = _boundary(p, edges, edge, cost, cap)
    sub, contrast = _subpixel(features, rows)
    return boundary_skyline(rows, sub, p.shape[0]), rows, contrast


def fit(photos: int = 0, weights: str | None = None, write: bool = True, net_width: int = NET_WIDTH,
        held_out_weights: str | None = None) -> dict:
    """Fit on the dev photos (module doc); written beside ``weights`` (None: the shipped network)."""
    from sklearn.linear_model import LogisticRegression

    data = prepared(photos, weights, net_width, held_out_weights)
    best = None
    for edge, cost, cap in itertools.product(EDGE_BONUS, JUMP_COST, JUMP_CAP):
        scores = []
        for features, edges, p, truth in data:
            skyline, _, _ = skyline_with(features, edges, p, edge, cost, cap)
            scores.append(np.mean(column_errors(skyline, truth) <= 5))
        score = float(np.mean(scores))
        print(f"edge {edge:5.1f} jump {cost:4.2f} cap {cap:4.1f}: dev mean within 5 px {100 * score:.2f} %", flush=True)
        if best is None or score > best[0]:
            best = (score, edge, cost, cap)
    score, edge, cost, cap = best
    xs, ys = [], []
    for features, edges, p, truth in data:
        skyline, rows, contrast = skyline_with(features, edges, p, edge, cost, cap)
        xs.append(confidence_features(p, rows, contrast, skyline)[np.isfinite(truth)])
        ys.append(column_errors(skyline, truth) <= 5)
    x, y = np.concatenate(xs), np.concatenate(ys)
    model = LogisticRegression(C=1.0, max_iter=1000).fit(x, y) if len(set(y.tolist())) > 1 else None
    result = {"net_width": net_width, "net_edge_bonus": edge, "net_jump_cost": cost, "net_jump_cap": cap,
              "dev_mean_within5": score,
              "photos": len(data), "columns": int(len(y)), "columns_within5": float(np.mean(y)),
              "coef": model.coef_[0].tolist() if model else [0.0, 0.0, 0.0, 0.0],
              "intercept": float(model.intercept_[0]) if model else 10.0,
              "features": ["margin", "contrast/15", "roughness px", "1-|2p-1|"],
              "out_of_fold": bool(held_out_weights)}
    if write:
        with open(fitted_path(net_width, weights), "w") as f:
            json.dump(result, f, indent=1)
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=0, help="at most this many dev photos (0: all)")
    parser.add_argument("--weights", default=None, help="another network's ONNX file (to compare set-ups); "
                        "the fit is written beside it as <name>_fit.json")
    parser.add_argument("--held-out-weights", default=None, metavar="PATTERN",
                        help="cross-fitting: PATTERN.format(k) is the network trained without dev fold k")
    parser.add_argument("--net-width", type=int, default=NET_WIDTH, help="the network's input width (px)")
    parser.add_argument("--dry-run", action="store_true", help="print, do not write the fitted file")
    args = parser.parse_args(argv)
    r = fit(args.photos, args.weights, write=not args.dry_run, net_width=args.net_width,
            held_out_weights=args.held_out_weights)
    where = "" if args.dry_run else f"; written to {fitted_path(args.net_width, args.weights)}"
    print(f"best: edge bonus {r['net_edge_bonus']}, jump cost {r['net_jump_cost']}, jump cap {r['net_jump_cap']} "
          f"(dev mean within 5 px {100 * r['dev_mean_within5']:.2f} %){where}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
