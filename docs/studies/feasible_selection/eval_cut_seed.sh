#!/usr/bin/env bash
# Evaluate one seed of the label-command-cut arm (run from the repo root): S=1 or 2.
set -euo pipefail
S=$1
C=/root/wqwarp_runs/ab_cut/ours_wheels_kf_cut_s$S/model_4882.pt
O=docs/studies/feasible_selection
P=ours_wheels_kf_cut_s$S
. .venv/bin/activate
E="python train/evaluate.py --checkpoint $C"
$E --preset ours --tasks stand,vx,vy,wz --num-envs 100 --seconds 20 --seed 1 --json $O/${P}_tracking.json
$E --preset ours --tasks stand,vx,vy,wz --num-envs 100 --seconds 20 --seed 1 --criterion kinematic --json $O/${P}_as_kinematic_tracking.json
$E --protocol lateral --json $O/lateral_${P}.json
$E --protocol energymap --seed 1 --json $O/${P}_energymap.json --png $O/${P}_energymap.png
$E --protocol energymap --seed 1 --criterion kinematic --json $O/${P}_energymap_as_kinematic.json
$E --preset ours --protocol push --num-envs 100 --seconds 31 --push-interval 7.5 --seed 1 --json $O/${P}_push.json
$E --preset ours --protocol timeline --robots 1 --segments "0,0,0:4;0.8,0,0:4;0,0,0.6:4;0,0.4,0:4" --seed 1 --json $O/${P}_timeline.json --png $O/${P}_timeline.png
echo done $S
