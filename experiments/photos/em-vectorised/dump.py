"""Dump select/gmm skylines (and time) for the dev side + CH1 validation photos, with whichever skyrender is on the path."""
import sys, time, numpy as np
from skyrender.datasets.real_photos import items_on_side
from skyrender.features import SkylineParams, extract_skyline, load_photo
out = sys.argv[1]
items = items_on_side("dev") + [it for it in items_on_side("validation") if it.key.startswith("ch1/")]
res, secs = {}, []
for it in items:
    im = load_photo(it.image_path)
    t = time.perf_counter(); s = extract_skyline(im, SkylineParams(method="select")); secs.append(time.perf_counter() - t)
    res[it.key.replace("/", "__")] = s.skyline
    res[it.key.replace("/", "__") + "__conf"] = s.confidence
np.savez(out, **res)
print(out, len(items), "median s", np.median(secs), "mean", np.mean(secs))
