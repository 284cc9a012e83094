#!/usr/bin/env bash
# Issue 20 on a lent two-GPU host, in four device calls (each under 10 minutes), after the warp-lang
# wheel's four transfer calls (../shared/tools/gpu-warp.sh), with .whl (gpu-wheels.sh) and .clips
# (a copy of ../shared/deepmimic/motions) carried:
#   bash experiments/multi_gpu/device_calls.sh 1   # parity, bench on 1 and 2 GPUs, the backflip on 2
#   bash experiments/multi_gpu/device_calls.sh 2   # bench on 1 GPU, then the backflip on 1 GPU, seeds 0 and 1
#   bash experiments/multi_gpu/device_calls.sh 3   # the backflip on 2 GPUs, seed 1
#   bash experiments/multi_gpu/device_calls.sh 4   # the backflip on 1 GPU, seed 0, the other GPU idle
#   bash experiments/multi_gpu/device_calls.sh 5   # on a four-GPU host: bench on 1, 2 and 4 GPUs
# Results land in $OUT (experiments/multi_gpu/README.md).
set -u
export PYTHONUNBUFFERED=1 MJXMIMIC_CLIPS=$PWD/.clips
BF="--clip backflip --preset gpu --set run.total_samples=100000000 --set run.target_nr=0.75"
nvidia-smi -L
if [ "$1" = 1 ]; then
  python3 benchmarks/multi_gpu_parity.py --preset gpu --clip walk --num-envs 1024 --steps 4 \
    --out "$OUT/parity.json" || exit 1
  CUDA_VISIBLE_DEVICES=0 python3 -m mjxmimic.cli bench --preset gpu --clip walk --kinds train_loop \
    --num-envs 8192 --out "$OUT/bench_1gpu.json" 2>&1 | grep -v -i warp
  python3 -m mjxmimic.cli bench --preset gpu --clip walk --kinds train_loop \
    --num-envs 16384 --out "$OUT/bench_2gpu.json" 2>&1 | grep -v -i warp
  # the same algorithm per sample as on 1 GPU: twice the envs, twice the minibatches (same size)
  PACK=policies bash experiments/device_train.sh 200 "bf_2gpu|$BF --set ppo.num_envs=16384 --set ppo.num_minibatches=16"
elif [ "$1" = 2 ]; then
  # the backflip on 1 GPU, seeds 0 and 1, one GPU each, after a 1-GPU bench that also fills
  # warp's kernel cache (a machine's first run would otherwise spend about 65 s compiling
  # kernels); compare the lanes' steady samples/s with the bench to see whether they slowed each other
  CUDA_VISIBLE_DEVICES=0 python3 -m mjxmimic.cli bench --preset gpu --clip walk --kinds train_loop \
    --num-envs 8192 --out "$OUT/bench_1gpu.json" 2>&1 | grep -v -i warp
  PACK=policies bash experiments/device_train.sh 330 "bf_1gpu|$BF" "bf_1gpu_s1|$BF --set run.seed=1"
elif [ "$1" = 3 ]; then
  # the backflip on 2 GPUs with seed 1 (the same machine, still warm after part 2)
  PACK=policies bash experiments/device_train.sh 200 \
    "bf_2gpu_s1|$BF --set ppo.num_envs=16384 --set ppo.num_minibatches=16 --set run.seed=1"
elif [ "$1" = 5 ]; then
  # the full loop on 1, 2 and 4 GPUs of one host, 8192 envs a GPU (the 1-GPU bench, first, also
  # fills warp's kernel cache)
  for n in 1 2 4; do
    CUDA_VISIBLE_DEVICES=$(seq -s, 0 $((n - 1))) python3 -m mjxmimic.cli bench --preset gpu --clip walk \
      --kinds train_loop --num-envs $((8192 * n)) --out "$OUT/bench_${n}gpu.json" 2>&1 | grep -v -i warp
  done
else
  # the backflip on 1 GPU, seed 0, with the other GPU idle
  CUDA_VISIBLE_DEVICES=0 PACK=policies bash experiments/device_train.sh 330 "bf_1gpu_alone|$BF"
fi
