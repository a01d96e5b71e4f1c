"""The fov-unknown rows with the far-horizon poses re-ranked (../rerank-fov-unknown/), with the other coarse fovs'
candidates refined too, and with both, against those without, on the 41 training-side photos, by the rules of README.md.

``python experiments/ch1/other-fov-runner-up/compare.py > experiments/ch1/other-fov-runner-up/compare.txt``
"""

import os

from skyrender.training.localize_fit import fov_unknown_runs_report

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = {name: [os.path.join(HERE, folder, f"bench-real-{s}-{tag.format(s=s)}.json") for s in ("train", "dev")]
        for name, folder, tag in [("shipped (../dem-window/unknown/)", "../dem-window/unknown", "unknown-{s}"),
                                 ("re-ranked (../rerank-fov-unknown/)", "../rerank-fov-unknown", "rerank-unknown"),
                                 ("other fovs refined (this folder)", "", "other-fov"),
                                 ("both: other fovs refined and re-ranked (this folder)", "", "both")]}

if __name__ == "__main__":
    print(fov_unknown_runs_report(RUNS))
