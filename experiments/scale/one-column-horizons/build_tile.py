"""``skyrender model`` of the SRTM3 tile N46E007 as ``make bench-scale`` times it (its own process,
seconds by stage, peak RSS), with whichever skyrender the working directory holds.

``python experiments/scale/one-column-horizons/build_tile.py OUT_DIR`` (run from the repository
root, or from a worktree's for the code before)."""

import json
import os
import sys

from skyrender.benchmarks import scale

if __name__ == "__main__":
    print(json.dumps(scale.build(os.path.join(scale.DEM_DIR, scale.TILE), sys.argv[1])))
