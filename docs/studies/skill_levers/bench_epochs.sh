#!/usr/bin/env bash
# Training throughput of the ours task at 128 robots with the PPO update's 5 epochs (the task's) and with 2, idle and
# with one core busy (run from the repo root, nothing else running): tools/bench_train.py, one JSON per setting.
set -euo pipefail
O=docs/studies/skill_levers
. .venv/bin/activate
for BUSY in 0 1; do
  for EP in 5 2; do
    python tools/bench_train.py --sizes 128 --iterations 6 --seconds 2 --num-learning-epochs $EP --busy $BUSY \
      --json $O/bench_epochs${EP}_busy${BUSY}.json | tee $O/bench_epochs${EP}_busy${BUSY}.log
  done
done
