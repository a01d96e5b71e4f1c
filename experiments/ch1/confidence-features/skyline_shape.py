"""Per photo of a side: how much shape its extracted skyline has (relief: 95th - 5th percentile row over the width;
tv: total variation over the width).  python experiments/ch1/confidence-features/skyline_shape.py SIDE OUT.json"""
import json, sys
import numpy as np
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.localizer import LocalizeParams

side = sys.argv[1]
params = LocalizeParams.for_photos().skyline_params()
out = {}
for it in items_on_side(side):
    if not it.key.startswith("ch1/"):
        continue
    img = load_photo(it.image_path)
    sky = extract_skyline(img, params).skyline
    W = len(sky)
    s = sky[np.isfinite(sky)]
    out[it.key] = {"relief": float((np.percentile(s, 95) - np.percentile(s, 5)) / W) if len(s) else 0.0,
                   "tv": float(np.abs(np.diff(s)).sum() / W) if len(s) > 1 else 0.0,
                   "sky_share": float(np.isfinite(sky).mean())}
json.dump(out, open(sys.argv[2], "w"))
