"""Two ``dump.py`` outputs: how many skylines and confidences differ (NaN equal to NaN).

``python experiments/photos/em-vectorised/compare.py BEFORE.npz AFTER.npz``"""

import sys

import numpy as np

a, b = np.load(sys.argv[1]), np.load(sys.argv[2])
differing = [k for k in a.files if not np.array_equal(a[k], b[k], equal_nan=True)]
print(f"{len(differing)} of {len(a.files)} arrays differ{': ' + ', '.join(differing) if differing else ''}")
