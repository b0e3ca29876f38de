#!/usr/bin/env bash
# Evaluate one seed of the yaw-limit arm (select with --env.predictor.kinematic-yaw-limit 10; run from the repo
# root): S=1 or 2. The same tasks, robots and seed as the reproduction's and the cut arm's evaluations.
set -euo pipefail
S=$1
C=runs/ab_yaw/yaw10_s$S/model_4882.pt
O=docs/studies/feasible_selection
P=ours_select_yaw10_s$S
. .venv/bin/activate
E="python train/evaluate.py --checkpoint $C"
$E --preset ours --tasks stand,vx,vy,wz --num-envs 100 --seconds 20 --seed 1 --json $O/${P}_tracking.json
$E --protocol energymap --seed 1 --json $O/${P}_energymap.json --png $O/${P}_energymap.png
echo done $S
