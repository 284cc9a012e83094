#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-second session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"), as it ran: calls of 460, 511, 256 and 301 s,
#   bash experiments/calls_s44_x2.sh 510 A
#   bash experiments/calls_s44_x2.sh 500 B
#   bash experiments/calls_s44_x2.sh 340 C              # seeds 6 and 7
#   MIN_LEFT=0 bash experiments/calls_s44_x2.sh 295 C 8 9
# Issue 20: the 1-GPU baseline for the backflip's time to NR 0.75 on today's code (multi_gpu/s43's
# split ran on it; s14's 1-GPU runs were of 2026-11-27's code): the preset of s14 and s43 (released
# reward, plain observation, no KL stop), 8192 envs on one GPU, one run a GPU side by side; a
# warm-up that fills JAX's compilation cache first, then each run started only while MIN_LEFT (230)
# s of its call are left. Issue 13, plan item 2(e): call A's lane 0 trained the crawl on today's
# preset with the twist heading frame (crawlT, 100 M samples); crawlTC (the same with central-
# difference reference velocities) never started, its lane going to the baseline after call A.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
then_preset="--preset gpu --set reward.kind=released --set env.observations=phase,root_height,bodies --set ppo.max_kl=0"
flip="--clip backflip $then_preset --set run.total_samples=100000000 --set run.target_nr=0.75"
crawl="--clip crawl --preset gpu --set env.observation_heading=twist"
b1n() { for seed in "$@"; do printf ';b1n_s%s|%s --set run.seed=%s' "$seed" "$flip" "$seed"; done; }
if [ "$2" = A ]; then
  PACK=none bash experiments/device_train.sh "$1" \
    "@0/230 crawlT|$crawl;crawlTC|$crawl --set clip.velocity=central;b1n_s6|$flip --set run.seed=6" \
    "@1/230 warm_1n|$flip$(b1n 2 3 4 5)"
elif [ "$2" = B ]; then
  PACK=none bash experiments/device_train.sh "$1" \
    "@0/230 $(b1n 5 6 | cut -c 2-)" "@1/230 $(b1n 3 4 | cut -c 2-)"
else
  PACK=none bash experiments/device_train.sh "$1" \
    "@0/${MIN_LEFT:-230} $(b1n "${3:-6}" | cut -c 2-)" "@1/${MIN_LEFT:-230} $(b1n "${4:-7}" | cut -c 2-)"
fi
