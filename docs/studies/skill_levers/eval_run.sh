#!/usr/bin/env bash
# Evaluate one lever arm's training (run from the repo root): RUN = its run folder, NAME = the result prefix,
# ITS = checkpoint iterations (default 2400: 7.38 M samples). The evaluation is the one of
# docs/studies/skill_every_seed/eval_seed.sh (evaluation seed 1 for every checkpoint: the same commands and pushes).
set -euo pipefail
RUN=$1
NAME=$2
O=docs/studies/skill_levers
. .venv/bin/activate
for IT in ${ITS:-2400}; do
  C=$RUN/model_$IT.pt
  python train/evaluate.py --checkpoint $C --preset ours --tasks stand,vx,vy,wz --num-envs 100 --seconds 20 --seed 1 \
    --json $O/${NAME}_it${IT}_tracking.json
  python train/evaluate.py --checkpoint $C --protocol lateral --seed 1 --json $O/${NAME}_it${IT}_lateral.json
done
echo done $NAME
