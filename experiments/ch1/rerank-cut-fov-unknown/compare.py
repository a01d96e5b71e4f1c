"""The fov-unknown rows with the re-ranking cut to the best 300 poses by each ranking, alone and with the far-horizon
verification on every 16th column, against the shipped rows, on the 41 training-side photos, by the rules of
README.md.

``python experiments/ch1/rerank-cut-fov-unknown/compare.py > experiments/ch1/rerank-cut-fov-unknown/compare.txt``
"""

import os

from skyrender.training.localize_fit import fov_unknown_runs_report

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = {name: [os.path.join(HERE, folder, f"bench-real-{s}-{tag}.json") for s in ("train", "dev")]
        for name, folder, tag in [("shipped (../other-fov-runner-up/)", "../other-fov-runner-up", "both"),
                                 ("cut to 300 by each ranking (this folder)", "", "cut300"),
                                 ("cut to 300 by each ranking, verified on every 16th column (this folder)", "",
                                  "cut300-v16")]}

if __name__ == "__main__":
    print(fov_unknown_runs_report(RUNS))
