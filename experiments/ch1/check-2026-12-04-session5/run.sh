#!/bin/bash
# 10 validation photos spread over the places (fov known; every 5th also with the fov unknown), no abstention, every
# refined pose kept: the code at this session's start (a worktree at 67cb47f) and then this code, one after the other.
#   bash experiments/ch1/check-2026-12-04-session5/run.sh /work/w_old
OLD=$1
NEW=$(cd "$(dirname "$0")/../../.." && pwd)
OUT=$NEW/experiments/ch1/check-2026-12-04-session5
ARGS="--side validation --limit 10 --fov known unknown --unknown-every 5 --no-abstain --out $OUT"
(cd "$OLD" && PYTHONPATH=$OLD $NEW/.venv/bin/python -m skyrender.benchmarks.real_localize $ARGS --tag before) > $OUT/before.log 2>&1
(cd "$NEW" && $NEW/.venv/bin/python -m skyrender.benchmarks.real_localize $ARGS --tag after) > $OUT/after.log 2>&1
