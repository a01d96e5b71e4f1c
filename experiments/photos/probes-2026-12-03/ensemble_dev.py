"""Dev probe: the sky network as an ensemble (mean logits of several ONNX files)."""
import json
import os
import sys
import tempfile

import cv2
import numpy as np

import skyrender.features.skyline as sk
from skyrender.benchmarks.skyline_photos import evaluate, summary
from skyrender.datasets.real_photos import items_on_side
from skyrender.features.sky_net import WEIGHTS, sky_logits

nets = [WEIGHTS] + sys.argv[1:]
def net_probability(image, weights=None, net_width=sk.NET_WIDTH):
    H, W = image.shape[:2]
    logits = np.mean([sky_logits(image, net_width, weights=w) for w in nets], axis=0)
    logits = cv2.resize(logits, (W, H), interpolation=cv2.INTER_LINEAR)
    return (1.0 / (1.0 + np.exp(-np.clip(logits, -30, 30)))).astype(np.float32)
sk.net_probability = net_probability
rows = evaluate(items_on_side('dev'), ['hybrid', 'net'], progress=False)
for m in ['hybrid', 'net']:
    s = summary(rows, m)
    print(m, 'met', s['met'], 'mean', round(100 * s['mean_within5'], 1), 'lowest', round(100 * s['min_within5'], 1))
json.dump(rows, open(os.path.join(tempfile.gettempdir(), 'ensemble_dev.json'), 'w'))
