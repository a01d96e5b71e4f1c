"""Dev probe: grid of the hybrid's final boundary-search weights (edge bonus, jump cost, jump cap, texture)."""
import itertools
import json
import os
import pickle
import sys
import tempfile

import numpy as np

import skyrender.features.skyline as sk
from skyrender.benchmarks.skyline_photos import column_errors, meets_target
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, load_photo
from skyrender.features.sky import pixel_features

side = sys.argv[1] if len(sys.argv) > 1 else 'dev'
cache = os.path.join(tempfile.gettempdir(), f'hybrid_cache_{side}.pkl')
params = SkylineParams(method='hybrid')
if os.path.exists(cache):
    data = pickle.load(open(cache, 'rb'))
else:
    data = []
    for it in items_on_side(side):
        image = load_photo(it.image_path)
        assert image.shape[1] <= params.work_width
        features = pixel_features(image)
        edges = sk._edge_strength(features, params.edge_percentile)
        p_net = sk.net_probability(image)
        rows = sk._boundary(p_net, edges, *sk._net_boundary_weights(params))
        p = sk._hybrid_probability(features, p_net, rows, params)
        grad = features[..., 4]
        tex = np.clip(grad / max(float(np.percentile(grad, 90)), 1e-3), 0, 1).astype(np.float32)
        data.append((it.key, features[..., :3].astype(np.float32), edges.astype(np.float32), p, tex, it.truth_skyline()))
        print(it.key, flush=True)
    pickle.dump(data, open(cache, 'wb'))
grid = list(itertools.product([16, 32, 64, 128], [0.25, 1.0, 4.0], [12, 48, 96], [0.3, 0.0]))
if len(sys.argv) > 2:
    grid = [tuple(float(x) for x in sys.argv[2].split(','))]
res = []
for eb, jc, cap, tw in grid:
    w5, met = [], 0
    for key, lab, edges, p, tex, truth in data:
        rows = sk._boundary(p, edges, eb, jc, cap, tw * tex if tw else None)
        sub, _ = sk._subpixel(np.concatenate([lab, np.zeros(lab.shape[:2] + (2,), np.float32)], axis=2), rows)
        sky = sk.boundary_skyline(rows, sub, lab.shape[0])
        e = column_errors(sky, truth)
        w5.append(np.mean(e <= 5))
        met += meets_target(float(np.median(e)), float(np.mean(e <= 5)))
    res.append({'edge_bonus': eb, 'jump_cost': jc, 'jump_cap': cap, 'texture': tw, 'mean_within5': float(np.mean(w5)),
                'met': met, 'lowest': float(np.min(w5)), 'per_photo': [float(x) for x in w5]})
    print(eb, jc, cap, tw, f"{100*np.mean(w5):.1f}", met, f"{100*np.min(w5):.1f}", flush=True)
json.dump(res, open(os.path.join(tempfile.gettempdir(), f'hybrid_dp_grid_{side}.json'), 'w'))
