#!/usr/bin/env bash
# The Python packages the lent GPU machine lacks, as wheel pieces small enough to travel.
#
#   bash benchmarks/gpu_wheels.sh          # here, in the repository root, once
#
# The GPU machine's image has JAX 0.11.2 (CUDA 13), Flax, Optax and NumPy but not MuJoCo,
# MJX, Warp, Brax, dm_control or Gymnasium, and it cannot download them. The wheels for its
# Python 3.12 come to about 250 MB, warp-lang 1.18.0 alone 149 MB, while one device call
# carries 64 MiB with the working tree, whose tracked files take 34 MB (2026-11-26). So they
# go into one tar, cut into pieces of 25 MiB, `.gpu_wheels/part_*`, each in a folder of its
# own (`.gpu_wheels/p00`, `p01`, ...; ignored by git): about ten. On one warm machine, call
# k carries folder `pk` alone (ignored paths a call leaves are kept there for the next),
# and the last call joins and installs them:
#
#   cat .gpu_wheels/p*/part_* | tar -x -C /tmp && python3 -m pip install -q --no-index \
#     --no-deps --target /tmp/site /tmp/gpu_wheels/*.whl && export PYTHONPATH=/tmp/site:$PWD
#
# then runs `bash benchmarks/gpu_warp_check.sh $OUT`.
set -euo pipefail
grep -qxF '/.gpu_wheels/' .git/info/exclude 2>/dev/null || echo '/.gpu_wheels/' >>.git/info/exclude
rm -rf .gpu_wheels /tmp/gpu_wheels && mkdir -p .gpu_wheels /tmp/gpu_wheels
python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.12 \
  --implementation cp --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
  --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform any \
  -d /tmp/gpu_wheels \
  mujoco==3.17.0 mujoco-mjx==3.17.0 warp-lang==1.18.0 brax==0.14.2 dm-control==1.0.50 \
  dm-env dm-tree labmaze glfw pyopengl websockets trimesh jaxopt ml-collections tensorboardx \
  flask flask-cors itsdangerous blinker gymnasium farama-notifications "shimmy[dm-control]"
tar -C /tmp -cf - gpu_wheels | split -b 25M -d - .gpu_wheels/part_
for part in .gpu_wheels/part_*; do
  dir=".gpu_wheels/p${part##*_}"
  mkdir -p "$dir" && mv "$part" "$dir/"
done
ls -l .gpu_wheels/p*
