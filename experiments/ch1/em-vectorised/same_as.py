"""Two ``make bench-real`` runs of the same photos: are their answers the same?

``python experiments/ch1/em-vectorised/same_as.py BEFORE.json AFTER.json``: per photo and fov mode, whether
every refined pose (x, y, z, pan, tilt, swing, f, score) and the error are identical, and the seconds of each."""

import json
import sys

import numpy as np


def main(before: str, after: str) -> None:
    with open(before) as f:
        a = {(r["photo"], r["fov_mode"]): r for r in json.load(f)["photos"]}
    with open(after) as f:
        b = {(r["photo"], r["fov_mode"]): r for r in json.load(f)["photos"]}
    same, seconds = 0, []
    for key in sorted(set(a) & set(b)):
        ra, rb = a[key], b[key]
        poses = np.array_equal(np.asarray(ra["refined_poses"], float), np.asarray(rb["refined_poses"], float))
        error = ra.get("error_m", ra.get("withheld_error_m")) == rb.get("error_m", rb.get("withheld_error_m"))
        same += poses and error
        seconds.append((ra["seconds"], rb["seconds"]))
        if not (poses and error):
            print(f"{key[0]} ({key[1]}): refined poses {'same' if poses else 'DIFFER'}, error "
                  f"{ra.get('error_m', ra.get('withheld_error_m'))} -> {rb.get('error_m', rb.get('withheld_error_m'))}")
    s = np.array(seconds)
    print(f"{same} of {len(set(a) & set(b))} rows with every refined pose and the error identical; "
          f"median seconds {np.median(s[:, 0]):.1f} -> {np.median(s[:, 1]):.1f}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
