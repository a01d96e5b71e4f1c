"""``select`` at an earlier commit against the working tree, timed in turns photo by photo (the order alternating),
in one process: ``python experiments/photos/same-values-faster/paired.py COMMIT [N]`` (N CH1 photos spread over the
133, default 40). The commit's package is unpacked as ``skyrender_old`` under /tmp (the package imports itself
relatively, so both load side by side). Prints both medians and the median of the per-photo ratios."""
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

old, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 40
root = tempfile.mkdtemp(prefix="skyrender-old-")
subprocess.run(f"git archive {old} skyrender | tar -x -C {root} && mv {root}/skyrender {root}/skyrender_old",
               shell=True, check=True)
sys.path.insert(0, root)
import skyrender_old.features as old_features  # noqa: E402

import skyrender.features as new_features  # noqa: E402
from skyrender.datasets.real_photos import photo_items  # noqa: E402

ch1 = [i for i in photo_items() if i.key.startswith("ch1/")]
items = ch1[:: max(1, len(ch1) // n)][:n]
images = [new_features.load_photo(i.image_path) for i in items]
versions = {"old": (old_features.extract_skyline, old_features.SkylineParams(method="select")),
            "new": (new_features.extract_skyline, new_features.SkylineParams(method="select"))}
for extract, params in versions.values():
    extract(images[0], params)  # warm-up: the network loaded, numba's kernel compiled
seconds = {name: [] for name in versions}
for k, image in enumerate(images):
    for name in (["old", "new"] if k % 2 == 0 else ["new", "old"]):
        extract, params = versions[name]
        t = time.perf_counter()
        extract(image, params)
        seconds[name].append(time.perf_counter() - t)
shutil.rmtree(root)
o, w = np.array(seconds["old"]), np.array(seconds["new"])
print(f"{len(images)} CH1 photos, select: {old} {np.median(o):.3f} s, working tree {np.median(w):.3f} s (medians); "
      f"median per-photo ratio {np.median(w / o):.3f}")
