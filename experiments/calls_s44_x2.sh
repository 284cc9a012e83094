#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-second session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"); every call runs the same command:
#   bash experiments/calls_s44_x2.sh SECONDS                  # calls A and B
#   PACK=policies bash experiments/calls_s44_x2.sh SECONDS    # the last call
# Lane 1 (GPU 1), issue 20: the 1-GPU baseline for the backflip's time to NR 0.75 on today's code
# (multi_gpu/s43's split ran on it; s14's 1-GPU runs were of 2026-11-27's code): the preset of
# s14 and s43 (released reward, plain observation, no KL stop), 8192 envs on one GPU, a warm-up
# that fills JAX's compilation cache, then seeds 2 to 5, each started only while 230 s are left.
# Lane 0 (GPU 0), issue 13, plan item 2(e) and (d): the crawl on today's preset with the twist
# heading frame (crawlT), and with the central-difference reference velocities too (crawlTC),
# 100 M samples each; then the baseline's seed 6.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
then_preset="--preset gpu --set reward.kind=released --set env.observations=phase,root_height,bodies --set ppo.max_kl=0"
flip="--clip backflip $then_preset --set run.total_samples=100000000 --set run.target_nr=0.75"
crawl="--clip crawl --preset gpu --set env.observation_heading=twist"
baseline="warm_1n|$flip"
for seed in 2 3 4 5; do baseline="$baseline;b1n_s$seed|$flip --set run.seed=$seed"; done
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "@0/230 crawlT|$crawl;crawlTC|$crawl --set clip.velocity=central;b1n_s6|$flip --set run.seed=6" \
  "@1/230 $baseline"
