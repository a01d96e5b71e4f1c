"""The fov-given validation rows of this change beside the shipped run's (the make bench-real run at 6b0403f,
bench-real-validation-shipped-6b0403f.json here):
refined poses to the bit for the photos whose given fov the fov-unknown search reaches, and every status, error and
confidence that moved, with what the second opinion found.

    python experiments/ch1/telephoto-second-opinion/against_shipped.py NEW.json [SHIPPED.json]
"""
import json
import sys

import numpy as np

from skyrender.camera import horizontal_fov
from skyrender.datasets.real_photos import photo_items
from skyrender.localizer import LocalizeParams
from skyrender.localizer.pipeline import fov_within_reach


def known_rows(path: str) -> dict:
    return {r["photo"]: r for r in json.load(open(path))["photos"] if r["fov_mode"] == "known"}


def main() -> None:
    new = known_rows(sys.argv[1])
    shipped = "experiments/ch1/telephoto-second-opinion/bench-real-validation-shipped-6b0403f.json"
    old = known_rows(sys.argv[2] if len(sys.argv) > 2 else shipped)
    focal = {it.key: it.focal_px for it in photo_items() if it.focal_px}
    photo = LocalizeParams.for_photos()
    same, moved = 0, []
    within = 0
    for key, r in new.items():
        o = old[key]
        fov = horizontal_fov(r["width"], focal[key])
        reach = fov_within_reach(photo, fov)
        within += reach
        poses_same = r["refined_poses"] == o["refined_poses"]
        if reach:
            same += poses_same
        place = [(x or {}).get(k) for x in (r.get("second_opinion"), o.get("second_opinion")) for k in ("pose", "apart_m")]
        if r["status"] != o["status"] or not poses_same or place[:2] != place[2:]:
            so = r.get("second_opinion")
            moved.append(f"{key:32s} fov {fov:5.1f} {'within reach' if reach else 'scaled      '} "
                         f"{o['status']:9s} {o['confidence']:.3f} -> {r['status']:9s} {r['confidence']:.3f}; "
                         f"error {o.get('error_m', o.get('withheld_error_m', float('nan'))):.0f} -> "
                         f"{r.get('error_m', float('nan')):.0f} m; refined poses {'same' if poses_same else 'differ'}; "
                         + (f"second place {so['apart_m']:.0f} m apart, {so['seconds']:.1f} s" if so else "no second opinion")
                         + (f" (was {o['second_opinion']['apart_m']:.0f} m apart)" if o.get("second_opinion") else ""))
    every = sum(r["refined_poses"] == old[k]["refined_poses"] for k, r in new.items())
    print(f"{len(new)} photos; {within} with the given fov within the fov-unknown search's reach, {same} of them with "
          f"every refined pose of the shipped run to the bit ({every} of all {len(new)})")
    print("rows that moved (status, refined poses, or the second opinion's place; its seconds aside):")
    print("\n".join("  " + m for m in moved) or "  none")
    secs = np.array([r["seconds"] for r in new.values()])
    old_secs = np.array([o["seconds"] for o in old.values()])
    print(f"median seconds {np.median(secs):.1f} (shipped run {np.median(old_secs):.1f})")


if __name__ == "__main__":
    main()
