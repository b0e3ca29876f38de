#!/usr/bin/env bash
# Tracking evaluation of checkpoints of one run (run from the repo root), for the time-to-skill curves of issue 60:
# RUN = its run folder, NAME = the result prefix, ITS = checkpoint iterations. The protocol of
# docs/studies/skill_levers/eval_curve.sh (evaluation seed 1, 100 robots, 20 s per task, deterministic actions).
set -euo pipefail
RUN=$1
NAME=$2
O=docs/studies/fast_skill
. .venv/bin/activate
for IT in ${ITS:-500 999}; do
  python train/evaluate.py --checkpoint $RUN/model_$IT.pt --tasks stand,vx,vy,wz --num-envs 100 \
    --seconds 20 --seed 1 --json $O/${NAME}_it${IT}_tracking.json
done
echo done $NAME
