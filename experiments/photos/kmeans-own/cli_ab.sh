#!/bin/bash
# `skyrender skyline PHOTO --json` wall seconds, this tree and the code before (a worktree at $OLD), alternating
# N times: bash experiments/photos/kmeans-own/cli_ab.sh /work/w_old PHOTO N
OLD=$1; PHOTO=$2; N=${3:-5}
NEW=$(cd "$(dirname "$0")/../../.." && pwd)
PY=$NEW/.venv/bin/python
for i in $(seq 1 "$N"); do
  for side in old new; do
    dir=$([ $side = old ] && echo "$OLD" || echo "$NEW")
    t0=$(date +%s.%N)
    (cd "$dir" && PYTHONPATH=$dir $PY -m skyrender skyline "$PHOTO" --json > /tmp/cli_ab_$side.json)
    t1=$(date +%s.%N)
    echo "$side $(echo "$t1 - $t0" | bc)"
  done
done
cmp <($PY -c "import json,sys; print(json.load(open('/tmp/cli_ab_old.json'))['skyline'])") \
    <($PY -c "import json,sys; print(json.load(open('/tmp/cli_ab_new.json'))['skyline'])") && echo "the same skyline"
