#!/bin/bash
# 4 training photos, fov unknown, no abstention: the preset, then probes from the best 32 poses' centres by each
# ranking, then also 40 pairs per window in the probes (one after the other, nothing else running)
cd "$(dirname "$0")/../../.."
OUT=experiments/ch1/fov-probe-centres
P="ch1/IMG_4999_01024 ch1/IMG_5113_01024 ch1/IMG_5128_01024 ch1/IMG_4985_01024"
run() { .venv/bin/python -m skyrender.benchmarks.real_localize --side train --fov unknown --no-abstain --photos $P \
          --out $OUT --tag "$1" ${2:+--set "$2"} > $OUT/probe4-$1.log 2>&1; }
run base
run best32 '{"fov_probe_best": 32}'
run best32-pw40 '{"fov_probe_best": 32, "fov_probe_per_window": 40}'
