#!/usr/bin/env bash
# Evaluate one seed's training of the default task (run from the repo root): S = the seed, RUN = its run folder.
# Checkpoints after 2401 iterations (7.38 M samples) and after 4883 (15.0 M, the final one); the evaluation seed is
# 1 for every checkpoint (the same commands and pushes), as in docs/studies/feasible_selection/eval_cut_seed.sh.
set -euo pipefail
S=$1
RUN=${RUN:-runs/i47/ours_s$S}
O=docs/studies/skill_every_seed
. .venv/bin/activate
for IT in ${ITS:-2400 4882}; do
  C=$RUN/model_$IT.pt
  python train/evaluate.py --checkpoint $C --preset ours --tasks stand,vx,vy,wz --num-envs 100 --seconds 20 --seed 1 \
    --json $O/ours_s${S}_it${IT}_tracking.json
  python train/evaluate.py --checkpoint $C --protocol lateral --seed 1 --json $O/ours_s${S}_it${IT}_lateral.json
done
echo done $S
