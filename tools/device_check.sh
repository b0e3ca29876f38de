#!/usr/bin/env bash
# The GPU figures (CUDA throughput, training at 4096 robots, the device tests) in one prepared sequence, for a lent CUDA machine (run there from the project root,
# after ../shared/device/check.sh has installed the packages; see ../shared/device/README.md). Writes to $OUT:
#   bench_cuda_graph.json / bench_cuda_nograph.json   tools/bench.py at 1024 and 4096 robots, CUDA graph on / off
#   bench_train_cuda.json                             tools/bench_train.py at 1024 and 4096 robots
#   train_4096.log                                    200 training iterations of 4096 robots (the main job)
#   tests_cuda.log                                    the device-parametrised tests on cuda:0
# Each step has its own time limit so that one slow step cannot take the whole device budget.
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
export PYTHONUNBUFFERED=1
step() { echo "== $* ($(date +%T))"; }
step "bench, CUDA graph on"
timeout 200 python3 tools/bench.py --device cuda:0 --sizes 1024,4096 --json "$out/bench_cuda_graph.json" 2>&1 | tail -4
step "bench, CUDA graph off"
timeout 120 python3 tools/bench.py --device cuda:0 --sizes 1024,4096 --no-cuda-graph \
  --json "$out/bench_cuda_nograph.json" 2>&1 | tail -4
step "bench_train"
timeout 200 python3 tools/bench_train.py --device cuda:0 --sizes 1024,4096 --iterations 5 \
  --json "$out/bench_train_cuda.json" 2>&1 | tail -4
step "training, 4096 robots, 200 iterations"
timeout 400 python3 train/ppo_newton.py --device cuda:0 --num-envs 4096 --max-iterations 200 --log-dir /tmp/gpu_run \
  --no-export 2>&1 | tr '\r' '\n' | tee "$out/train_4096.log" | tail -8
step "device tests"
WQWARP_TEST_DEVICE=cuda:0 timeout 240 python3 -m pytest -q -x tests/sim tests/kernels tests/test_env.py \
  tests/test_device_path.py 2>&1 | tee "$out/tests_cuda.log" | tail -4
step done
