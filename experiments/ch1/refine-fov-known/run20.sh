#!/bin/bash
# The 20 training photos of fov-unknown-fast/, fov known, no abstention: the preset, then the focal length fitted in
# the refinement's last stage too (refine_fov), one after the other on an otherwise idle machine
cd "$(dirname "$0")/../../.."
OUT=experiments/ch1/refine-fov-known
P=$(.venv/bin/python -c "import json; print(' '.join(r['photo'] for r in json.load(open('experiments/ch1/fov-unknown-fast/bench-real-train-fast.json'))['photos']))")
run() { .venv/bin/python -m skyrender.benchmarks.real_localize --side train --fov known --no-abstain --photos $P \
          --out $OUT --tag "$1" ${2:+--set "$2"} > $OUT/run20-$1.log 2>&1; }
run base
run refine-fov '{"refine_fov": true}'
