#!/usr/bin/env bash
# The GPU measurements of the Warp backend and the training physics, as one device call.
#
#   bash benchmarks/gpu_warp_check.sh OUT_DIR
#
# Written for a lent NVIDIA GPU (15 minutes of device time: each step below has its own
# timeout, so that what finished comes back), after the packages it lacks are installed
# (benchmarks/gpu_wheels.sh says how they travel). It writes into OUT_DIR:
#   bench_mjx.log  control steps/s of both backends and both physics at 1,024, 8,192 and
#                  32,768 robots beside the 2-thread CPU vector env, same run, and PPO's
#                  env steps/s while training on 8,192 robots (benchmarks/bench_mjx.py);
#   bench_mjx_4_8.log  the same at 8,192 robots for the training physics with the solver
#                  capped at 4 / 8 (the candidate of docs/decisions.md#the-training-physics);
#   ppo_cpg_warp/  one PPO `cpg` run on Warp's training physics, 2.5 M env steps, its
#                  validations and wall time (baselines.ppo_mjx --test_seeds=0: the card is
#                  made afterwards on a CPU machine with --resume).
set -uo pipefail
out="${1:?usage: gpu_warp_check.sh OUT_DIR}"
mkdir -p "$out"
python3 -c "import jax, warp, mujoco.mjx; print(jax.devices())" >"$out/devices.txt" 2>&1 || exit 1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv >"$out/gpu.txt" 2>&1
timeout 300 python3 benchmarks/bench_mjx.py --batches=1024,8192,32768 --steps=20 \
  --impl=warp,jax --physics=training,reference --ppo_steps=1000000 --ppo_envs=8192 \
  >"$out/bench_mjx.log" 2>&1
timeout 90 python3 benchmarks/bench_mjx.py --batches=8192 --steps=20 --impl=warp,jax \
  --physics=training --iterations=4 --ls_iterations=8 >"$out/bench_mjx_4_8.log" 2>&1
timeout 200 python3 -m baselines.ppo_mjx --task=darwin_walk --action_space=cpg --impl=warp \
  --seed=0 --test_seeds=0 --output_dir="$out/ppo_cpg_warp" >"$out/ppo_cpg_warp.log" 2>&1
exit 0
