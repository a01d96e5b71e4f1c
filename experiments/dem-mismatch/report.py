"""The DEM-mismatch experiment's rows (``results/results.jsonl``) as one table, each dataset's configurations
together: the answers within 100 m / 250 m / 1 km of the truth and the confident wrong ones, then every view's best
place whether answered or withheld (what a better confidence could answer at most), the best refined score and the
seconds. Every row is rescored with the photo confidence shipped now (``skyrender/localizer/photo_confidence.json``:
its logistic of the margin and its threshold), so rows localized under an earlier fit count alike.
``python experiments/dem-mismatch/report.py`` from the repository root (writes ``report.txt`` beside it)."""

import json
import math
import os

import numpy as np

from skyrender.localizer.confidence import PHOTO_MARGIN_LOGIT, PHOTO_MIN_CONFIDENCE, margin_confidence

HERE = os.path.dirname(os.path.abspath(__file__))


def rescored(row: dict) -> tuple[float, float]:
    """(confidence under the shipped fit, error of the best place, answered or withheld; m)."""
    error = row["position_error_m"] if row["localized"] else row.get("withheld_error_m", math.inf)
    if row.get("best_score") is None:
        return 0.0, error
    runner_up = row["runner_up_score"] if row.get("runner_up_score") is not None else math.inf
    return margin_confidence(row["best_score"], runner_up, PHOTO_MARGIN_LOGIT, float(row.get("width", 1024))), error


def main() -> None:
    with open(os.path.join(HERE, "results", "results.jsonl")) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    first = {name: i for i, name in enumerate(dict.fromkeys(r["dataset"] for r in rows))}
    rows.sort(key=lambda r: first[r["dataset"]])
    head = (f"| dataset | configuration | views | answered (confidence >= {PHOTO_MIN_CONFIDENCE:.2f}) "
            "| answered within 100 / 250 / 1000 m | answered > 1 km (confidence) "
            "| best place within 100 / 250 / 1000 m, answered or withheld | median best score px | median s |")
    lines = [head, "|---" * 9 + "|"]
    for name, conf in dict.fromkeys((r["dataset"], r["configuration"]) for r in rows):
        group = [r for r in rows if (r["dataset"], r["configuration"]) == (name, conf)]
        scored = [rescored(r) for r in group]
        best = np.array([e for _, e in scored])
        answered = np.array([e for c, e in scored if c >= PHOTO_MIN_CONFIDENCE])
        wrong = [f"{e / 1000:.1f} km ({c:.2f})" for c, e in scored if c >= PHOTO_MIN_CONFIDENCE and e > 1000]
        scores = [r["best_score"] for r in group if r.get("best_score") is not None]
        lines.append(f"| {name} | {conf} | {len(group)} | {len(answered)} | "
                     + " / ".join(str(int((answered <= m).sum())) for m in (100, 250, 1000))
                     + f" | {', '.join(wrong) or 'none'} | " + " / ".join(str(int((best <= m).sum())) for m in (100, 250, 1000))
                     + f" | {np.median(scores):.2f} | {np.median([r['seconds'] for r in group]):.1f} |")
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(HERE, "report.txt"), "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    main()
