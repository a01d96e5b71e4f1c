"""The training side's localizations from the masks' skylines as localize_fit's rows file.

``python experiments/ch1/given-skyline/merge_rows.py bench-real-dev-true-skyline.json bench-real-train-true-skyline.json
> experiments/ch1/given-skyline/rows-training.json`` (the two ``real_localize --side dev|train --fov known --no-abstain
--true-skyline`` runs); ``localize_fit --from-rows --rows`` reads it."""
import json
import sys

runs = [json.load(open(path)) for path in sys.argv[1:]]
rows = [r for run in runs for r in run["photos"]]
commits = sorted({run["commit"] for run in runs})
json.dump({"commit": " + ".join(commits), "rows": rows}, sys.stdout)
print(f"{len(rows)} rows of {len(runs)} runs at {', '.join(commits)}", file=sys.stderr)
