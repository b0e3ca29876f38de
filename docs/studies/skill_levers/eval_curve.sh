#!/usr/bin/env bash
# Tracking evaluation of earlier checkpoints of one run (run from the repo root), for the time-to-skill curves:
# RUN = its run folder, NAME = the result prefix, ITS = checkpoint iterations (default 600 1200 1800: 1.84 / 3.69 /
# 5.53 M samples). The same command as eval_run.sh's tracking stage (evaluation seed 1, 100 robots, 20 s per task).
set -euo pipefail
RUN=$1
NAME=$2
O=docs/studies/skill_levers
. .venv/bin/activate
for IT in ${ITS:-600 1200 1800}; do
  python train/evaluate.py --checkpoint $RUN/model_$IT.pt --preset ours --tasks stand,vx,vy,wz --num-envs 100 \
    --seconds 20 --seed 1 --json $O/${NAME}_it${IT}_tracking.json
done
echo done $NAME
