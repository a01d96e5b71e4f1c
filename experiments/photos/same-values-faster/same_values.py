"""Every photo of the split (207) extracted with ``select``; the skylines and column confidences saved
(``python experiments/photos/same-values-faster/same_values.py save OUT.npz``) and two such files compared
(``... compare A.npz B.npz``): how many skylines are the same to the bit, and the largest confidence change."""
import sys
import time

import numpy as np

if sys.argv[1] == "save":
    from skyrender.datasets.real_photos import photo_items
    from skyrender.features import SkylineParams, extract_skyline, load_photo

    params, saved, seconds = SkylineParams(method="select"), {}, []
    for it in photo_items():
        image = load_photo(it.image_path)
        t = time.perf_counter()
        result = extract_skyline(image, params)
        seconds.append(time.perf_counter() - t)
        saved[it.key + "|skyline"], saved[it.key + "|confidence"] = result.skyline, result.confidence
    np.savez_compressed(sys.argv[2], **saved)
    print(f"{len(seconds)} photos, median {np.median(seconds):.3f} s")
else:
    a, b = np.load(sys.argv[2]), np.load(sys.argv[3])
    keys = [k.split("|")[0] for k in a.files if k.endswith("|skyline")]
    differ = [k for k in keys if not np.array_equal(a[k + "|skyline"], b[k + "|skyline"], equal_nan=True)]
    change = max(float(np.max(np.abs(a[k + "|confidence"] - b[k + "|confidence"]))) for k in keys)
    print(f"{len(keys) - len(differ)} of {len(keys)} skylines the same to the bit; largest confidence change {change:.3g}"
          + (f"; differing: {', '.join(differ)}" if differ else ""))
