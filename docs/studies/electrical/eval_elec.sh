#!/usr/bin/env bash
# Tracking evaluation of one training's checkpoint under both power measures (run from the repo root): RUN = its run
# folder, NAME = the result prefix, IT = the checkpoint iteration (default 2999: the 9.2 M budget). The evaluation of
# docs/studies/skill_levers/eval_run.sh (evaluation seed 1, 100 robots x 20 s per task, stand, v_x, v_y, w); every
# result JSON carries p_cost and p_elec (legs, wheels, copper) and both costs of transport. With NOMINAL=1 also the
# nominal driving gait alone (--zero-residual --force-gait driving, as the reproduction's nominal stage) on stand and v_x;
# with PUSH=1 also Table III's pushes as the reproduction's cpu budget runs them (100 robots x 31 s, a push up to 0.5 and
# up to 0.7 m/s every 7.5 s). PRESET = the method evaluated (default ours; no_predictor for the fixed trot).
set -euo pipefail
RUN=$1
NAME=$2
IT=${IT:-2999}
PRESET=${PRESET:-ours}
O=docs/studies/electrical
. .venv/bin/activate
python train/evaluate.py --checkpoint $RUN/model_$IT.pt --preset $PRESET --tasks stand,vx,vy,wz --num-envs 100 \
  --seconds 20 --seed 1 --json $O/${NAME}_it${IT}_tracking.json
if [ "${NOMINAL:-0}" = 1 ]; then
  python train/evaluate.py --checkpoint $RUN/model_$IT.pt --preset $PRESET --tasks stand,vx --num-envs 100 \
    --seconds 20 --seed 1 --zero-residual --force-gait driving --json $O/${NAME}_it${IT}_nominal.json
fi
if [ "${PUSH:-0}" = 1 ]; then
  python train/evaluate.py --protocol push --checkpoint $RUN/model_$IT.pt --preset $PRESET --num-envs 100 \
    --seconds 31 --push-interval 7.5 --seed 1 --json $O/${NAME}_it${IT}_push.json
fi
echo done $NAME
