"""The photo confidence refitted on the training-side rows of the shipped extractor (the EM's smaller budget), beside
the shipped fit; and where each fit puts the validation rows (read, never fitted on).

``python experiments/photos/em-budget/shipped/refit.py > experiments/photos/em-budget/shipped/refit.txt``

The fov-known rows are ``../localize/bench-real-{train,dev}-em-budget.json`` (73 photos, no abstention, the package of
b3845fc); the fov-unknown and second-search rows are this folder's ``bench-real-{train,dev}-unknown.json`` and
``bench-real-dev-second-telephoto.json`` (the same code; the fov-unknown ones, until they are there, the shipped
fit's). The refit
is written to ``refit-photo-confidence.json``. Then each fit's confidence of every validation row of
``../localize/bench-real-validation-em-budget*.json`` whose place would be answered differently by the two fits.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", "..", "..", ".."))
LOCALIZE = os.path.join(HERE, "..", "localize")
SHIPPED_FIT = os.path.join(REPO, "skyrender", "localizer", "photo_confidence.json")


def _rows(path: str) -> list[dict]:
    with open(path) as f:
        return json.load(f)["photos"]


def main() -> None:
    from skyrender.benchmarks.real_localize import margin_of
    from skyrender.localizer.confidence import margin_logistic

    rows = _rows(os.path.join(LOCALIZE, "bench-real-train-em-budget.json")) + \
        _rows(os.path.join(LOCALIZE, "bench-real-dev-em-budget.json"))
    rows_file = os.path.join(HERE, "refit-rows.tmp.json")
    with open(rows_file, "w") as f:
        json.dump({"commit": "89f1da0+em-budget.patch (the package of b3845fc)", "rows": rows}, f)
    with open(SHIPPED_FIT) as f:
        shipped = json.load(f)
    ours = [os.path.join(HERE, n) for n in ("bench-real-train-unknown.json", "bench-real-dev-unknown.json")]
    second = os.path.join(HERE, "bench-real-dev-second-telephoto.json")
    unknown = ours if all(map(os.path.exists, ours)) else [os.path.join(REPO, p) for p in shipped["fov_unknown_rows"]["files"]]
    second_rows = unknown + [second]
    out = os.path.join(HERE, "refit-photo-confidence.json")
    cmd = [sys.executable, "-m", "skyrender.training.localize_fit", "--from-rows", "--rows", rows_file, "--out", out,
           "--fov-unknown-rows", *unknown, "--second-opinion-rows", *second_rows]
    print("$", " ".join(os.path.relpath(c, REPO) if os.path.isabs(c) and c.startswith(REPO) else c for c in cmd[1:]))
    print(subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1])
    os.remove(rows_file)
    with open(out) as f:
        refit = json.load(f)
    for name, fit in (("shipped", shipped), ("refit", refit)):
        a, b = fit["logit"][:2]
        print(f"{name}: logit {a:.3f} + {b:.3f} m; margin at the 0.95 threshold {(np.log(19) - a) / b:.3f}; "
              f"fov unknown threshold {fit['min_confidence_fov_unknown']:.2f}; second opinion gain "
              f"{fit['second_opinion']['gain']:.2f} from {fit['second_opinion']['from']:.2f}")
    print("\nvalidation rows (read only) whose answer the two fits' margin rules would give differently:")
    print(f"{'photo':34s} {'fov':8s} {'margin':>6s} {'shipped':>7s} {'refit':>7s} {'best place off':>14s}")
    for tag in ("", "-unknown"):
        for r in _rows(os.path.join(LOCALIZE, f"bench-real-validation-em-budget{tag}.json")):
            m = margin_of(r, 1000.0)
            if not np.isfinite(m):
                continue
            c = [float(margin_logistic(m, tuple(fit["logit"]))) for fit in (shipped, refit)]
            t = [(fit["min_confidence_fov_unknown"] if r["fov_mode"] == "unknown" else fit["min_confidence"])
                 for fit in (shipped, refit)]
            if (c[0] >= t[0]) != (c[1] >= t[1]):
                poses = np.asarray(r["refined_poses"])
                best = poses[np.argmin(poses[:, 7])]
                off = float(np.hypot(*(best[:2] - np.asarray(r["truth_xy"]))))
                print(f"{r['photo']:34s} {r['fov_mode']:8s} {m:6.3f} {c[0]:7.3f} {c[1]:7.3f} {off:12.0f} m")


if __name__ == "__main__":
    main()
