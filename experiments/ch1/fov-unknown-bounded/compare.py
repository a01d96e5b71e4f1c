"""The fov-unknown rows with each candidate's focal length held within +-5 % against those without the bound, on the
41 training-side photos, by the rule of README.md.

``python experiments/ch1/fov-unknown-bounded/compare.py > experiments/ch1/fov-unknown-bounded/compare.txt``
"""

import os

from skyrender.training.localize_fit import fov_unknown_runs_report

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = {name: [os.path.join(HERE, folder, f"bench-real-{s}-{tag.format(s=s)}.json") for s in ("train", "dev")]
        for name, folder, tag in [("unbounded (../dem-window/unknown/)", "../dem-window/unknown", "unknown-{s}"),
                                 ("+-5 % (this folder)", "", "bounded")]}

if __name__ == "__main__":
    print(fov_unknown_runs_report(RUNS))
