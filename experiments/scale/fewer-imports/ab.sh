#!/bin/bash
# bench-scale's synthetic row, the code before (worktree $1) and this tree, alternating ($2 rounds), into
# experiments/scale/fewer-imports/$TAG (default "both"):
#   TAG=both bash experiments/scale/fewer-imports/ab.sh /work/w_old 2
OLD=$1; N=${2:-2}
NEW=$(cd "$(dirname "$0")/../../.." && pwd)
OUT=$NEW/experiments/scale/fewer-imports/${TAG:-both}
mkdir -p "$OUT"
for i in $(seq 1 "$N"); do
  for side in old new; do
    dir=$([ $side = old ] && echo "$OLD" || echo "$NEW")
    (cd "$dir" && PYTHONPATH=$dir $NEW/.venv/bin/python -m skyrender.benchmarks.scale --rows synthetic --out "$OUT/$side-$i") \
      > "$OUT/$side-$i.log" 2>&1
  done
done
