"""The DEM-mismatch experiment's rows (``results/results.jsonl``) as one table: per dataset, the answers within
100 m / 250 m / 1 km of the truth and the confident wrong ones, then every view's best place whether answered or
withheld (what a better confidence could answer at most), the best refined score and the seconds.
``python experiments/dem-mismatch/report.py`` from the repository root (writes ``report.txt`` beside it); a dataset's rows together."""

import json
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def main() -> None:
    with open(os.path.join(HERE, "results", "results.jsonl")) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    first = {name: i for i, name in enumerate(dict.fromkeys(r["dataset"] for r in rows))}
    rows.sort(key=lambda r: first[r["dataset"]])  # each dataset's configurations together, in the order run
    head = ("| dataset | configuration | views | answered | answered within 100 / 250 / 1000 m | answered > 1 km (confidence) "
            "| best place within 100 / 250 / 1000 m, answered or withheld | median best score px | median s |")
    lines = [head, "|---" * 9 + "|"]
    for name, conf in dict.fromkeys((r["dataset"], r["configuration"]) for r in rows):
        group = [r for r in rows if (r["dataset"], r["configuration"]) == (name, conf)]
        answered = [r["position_error_m"] for r in group if r["localized"]]
        wrong = [f"{r['position_error_m'] / 1000:.1f} km ({r['confidence']:.2f})" for r in group
                 if r["localized"] and r["position_error_m"] > 1000]
        best = np.array([r["position_error_m"] if r["localized"] else r.get("withheld_error_m", np.inf) for r in group])
        scores = [r["best_score"] for r in group if r.get("best_score") is not None]
        a = np.array(answered)
        lines.append(f"| {name} | {conf} | {len(group)} | {len(a)} | " + " / ".join(str(int((a <= m).sum())) for m in (100, 250, 1000))
                     + f" | {', '.join(wrong) or 'none'} | " + " / ".join(str(int((best <= m).sum())) for m in (100, 250, 1000))
                     + f" | {np.median(scores):.2f} | {np.median([r['seconds'] for r in group]):.1f} |")
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(HERE, "report.txt"), "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    main()
