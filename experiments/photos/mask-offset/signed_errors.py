"""Signed skyline error (extracted - mask, px; + = the line below the mask's edge) per CH1 photo, by place and side."""
import json, sys, numpy as np
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import extract_skyline, load_photo
from skyrender.features.skyline import SkylineParams
split = json.load(open('experiments/photos/split.json'))['photos']
out = []
for side in ('train', 'dev', 'validation'):
    for it in items_on_side(side):
        if not it.key.startswith('ch1/'): continue
        img = load_photo(it.image_path); t = it.truth_skyline()
        ex = extract_skyline(img, SkylineParams(method='select'))
        e = ex.skyline - t; ok = np.isfinite(e) & (np.abs(e) < 5)
        out.append({'photo': it.key, 'side': side, 'place': split[it.key]['place'], 'signed_median': float(np.median(e[ok])) if ok.any() else None,
                    'share_below': float(np.mean(e[ok] > 0)) if ok.any() else None})
        print(out[-1], flush=True)
json.dump(out, open(sys.argv[1], 'w'), indent=1)
