"""Each CH1 photo's answer before and after the DEM windows were grown to whole cells (`shift.py`): the best refined
pose's error (answered or withheld), its margin and its confidence under a given photo-confidence fit.

    python experiments/ch1/dem-window/compare.py OLD.json NEW.json [--fit FIT.json] [--old-fit FIT.json] [--fov unknown]

OLD / NEW: `real_localize` runs (`{"photos": rows}`) or `localize_fit` rows (`{"rows": rows}`). Each side is scored
with its fit (default the shipped `skyrender/localizer/photo_confidence.json`): logistic of the margin, answered at
its `min_confidence` (with `--fov unknown`, the rows localized with the fov unknown, answered at the fit's
`min_confidence_fov_unknown`; the summary also counts the photos narrower than 30 degrees, which that search does not
reach).
"""

import argparse
import json

import numpy as np

from skyrender.benchmarks.real_localize import log_best_of, margin_of, refined_of
from skyrender.localizer.confidence import PHOTO_CONFIDENCE_FILE
from skyrender.training.localize_fit import confidences


def load_rows(path, mode="known"):
    with open(path) as f:
        data = json.load(f)
    rows = data.get("photos", data.get("rows"))
    return {r["photo"]: r for r in rows if r.get("fov_mode", "known") == mode}


def true_fovs():
    """{photo key: true horizontal fov, degrees} of the CH1 photos (their given focal length)."""
    from skyrender.datasets.real_photos import items_on_side
    from skyrender.features.photo_io import load_photo

    out = {}
    for side in ("train", "dev", "validation"):
        for it in items_on_side(side):
            if it.key.startswith("ch1/"):
                width = load_photo(it.image_path).shape[1]
                out[it.key] = float(np.degrees(2 * np.arctan(width / (2 * it.focal_px))))
    return out


def best_error(row):
    """Metres from the truth to the best refined pose (the answer, given or withheld)."""
    poses = refined_of(row)
    if not len(poses):
        return float("inf")
    best = poses[int(np.argmin(poses[:, 7]))]
    return float(np.hypot(best[0] - row["truth_xy"][0], best[1] - row["truth_xy"][1]))


def scored(row, fit, mode="known"):
    margin = margin_of(row, fit["runner_up_m"])
    confidence = float(confidences(np.array([margin]), np.array([log_best_of(row)]), fit["logit"])[0])
    threshold = fit.get("min_confidence_fov_unknown", fit["min_confidence"]) if mode == "unknown" else fit["min_confidence"]
    return best_error(row), margin, confidence, confidence >= threshold


def summary(name, scores):
    err = np.array([s[0] for s in scores])
    answered = np.array([s[3] for s in scores])
    shown = np.where(answered, err, np.inf)
    within = np.isfinite(err) & (err <= 1000)
    return (f"{name}: {len(scores)} photos; answered within 100 / 250 / 1000 m: "
            f"{int(np.sum(shown <= 100))} / {int(np.sum(shown <= 250))} / {int(np.sum(shown <= 1000))}; answered "
            f"{int(answered.sum())}, wrong among them {int(np.sum(answered & ~within))}; best place within 1 km "
            f"{int(within.sum())}; median error within 1 km {np.median(err[within]):.0f} m")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--old-fit", default=PHOTO_CONFIDENCE_FILE)
    parser.add_argument("--fit", default=PHOTO_CONFIDENCE_FILE, help="the new rows' photo-confidence fit")
    parser.add_argument("--fov", default="known", choices=["known", "unknown"], help="which rows to compare")
    args = parser.parse_args(argv)
    old, new = load_rows(args.old, args.fov), load_rows(args.new, args.fov)
    with open(args.old_fit) as f:
        old_fit = json.load(f)
    with open(args.fit) as f:
        new_fit = json.load(f)
    keys = [k for k in old if k in new]
    print(f"{'photo':32s} {'old m':>8s} {'margin':>6s} {'conf':>5s}   {'new m':>8s} {'margin':>6s} {'conf':>5s}")
    olds, news = [], []
    for k in keys:
        o, n = scored(old[k], old_fit, args.fov), scored(new[k], new_fit, args.fov)
        olds.append(o)
        news.append(n)
        mark = lambda s: "*" if s[3] else " "  # noqa: E731  answered
        print(f"{k:32s} {o[0]:8.0f} {o[1]:6.3f} {o[2]:5.2f}{mark(o)}  {n[0]:8.0f} {n[1]:6.3f} {n[2]:5.2f}{mark(n)}")
    print("* answered (confidence at or above the fit's threshold)")
    key = "min_confidence_fov_unknown" if args.fov == "unknown" else "min_confidence"
    print(f"old fit: logit {old_fit['logit']}, threshold {old_fit.get(key)}; "
          f"new fit: logit {new_fit['logit']}, threshold {new_fit.get(key)}")
    print(summary("old", olds))
    print(summary("new", news))
    if args.fov == "unknown":
        narrow = {k for k, fov in true_fovs().items() if fov < 30.0}
        for name, scores in (("old", olds), ("new", news)):
            hits = sum(s[0] <= 1000 for k, s in zip(keys, scores) if k in narrow)
            print(f"{name}: best place within 1 km on {hits} of the {sum(k in narrow for k in keys)} photos narrower "
                  "than 30 degrees")
    both = [(o[0], n[0]) for o, n in zip(olds, news) if o[0] <= 1000 and n[0] <= 1000]
    if both:
        d = np.array([n - o for o, n in both])
        print(f"photos within 1 km both times: {len(both)}; new - old error median {np.median(d):+.0f} m, "
              f"{int(np.sum(d < 0))} closer, {int(np.sum(d > 0))} farther")


if __name__ == "__main__":
    main()
