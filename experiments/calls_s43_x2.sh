#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-first session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"), in two phases:
#   bash experiments/calls_s43_x2.sh 2gpu SECONDS                    # calls A to C: both GPUs
#   PACK=policies bash experiments/calls_s43_x2.sh lanes SECONDS     # call D: one lane a GPU
# Issue 20 (phase 2gpu): one GPU's batch split over two (8192 envs, 4096 a GPU: the same PPO per
# iteration as on one GPU, iterations faster), the backflip timed to NR 0.75 as the 1-GPU runs of
# multi_gpu/s14 were (the preset of then: released reward, plain observation, no KL stop). First,
# once per machine, the full loop's bench on GPU 0 alone (4096 and 8192 envs; it also fills Warp's
# kernel cache) and on both GPUs (8192 and 16384), then a warm-up that fills JAX's compilation
# cache, then seeds 3, 4, 5, ..., each started only while MIN_LEFT (230) s of the call are left.
# Issue 13 (phase lanes), plan item 2a: PPO's KL stop at 2 instead of the preset's 0.5, on the
# kick (which blew up without a stop) and the crawl (70 % of its steps undone at 0.5), 100 M each.
# Ran as calls of 404 s (2gpu 530: the benches, the warm-up and b2s_s3), 316 s (2gpu 535: b2s_s4,
# b2s_s5; b2s_s2 found 228 s left), 332 s (MIN_LEFT=200 ... 2gpu 370: b2s_s2, b2s_s6) and 374 s
# (PACK=policies ... lanes 470) after twenty-eight transfer calls.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
then_preset="--preset gpu --set reward.kind=released --set env.observations=phase,root_height,bodies --set ppo.max_kl=0"
split="--clip backflip $then_preset --set run.total_samples=100000000 --set run.target_nr=0.75"
if [ "$1" = 2gpu ]; then
  end=$(( $(date +%s) + $2 ))
  if [ ! -f runs/.benched ]; then
    mkdir -p /tmp/bench runs
    export MJXMIMIC_CLIPS=$PWD/.clips
    nvidia-smi -L
    for gpus_envs in "0|4096 8192|1gpu" "0,1|8192 16384|2gpu"; do
      IFS='|' read -r gpus envs name <<< "$gpus_envs"
      # shellcheck disable=SC2086
      CUDA_VISIBLE_DEVICES=$gpus python3 -m mjxmimic.cli bench --clip walk $then_preset --kinds train_loop \
        --num-envs $envs --out "/tmp/bench/bench_$name.json" > "/tmp/bench/bench_$name.log" 2>&1
    done
    touch runs/.benched
  fi
  runs="warm_2s|$split"
  for seed in 3 4 5 2 6 7 8; do runs="$runs;b2s_s$seed|$split --set run.seed=$seed"; done
  PACK=none bash experiments/device_train.sh $(( end - $(date +%s) )) "@0,1/${MIN_LEFT:-230} $runs"
else
  PACK=${PACK:-none} bash experiments/device_train.sh "$2" \
    "@0/30 kickK2|--clip kick --preset gpu --set ppo.max_kl=2" \
    "@1/30 crawlK2|--clip crawl --preset gpu --set ppo.max_kl=2"
fi
