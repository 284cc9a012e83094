#!/usr/bin/env bash
# The device calls of 2026-11-29 (thirtieth session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s32_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s32_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: the backflip's forward maximum between 620 N (bcSK: costs 0.009 and 0.013, but the
# forward force fell under 660 N) and 730 N (bcSI_s1: seed 1 costs 0.023). bcSM: 680 N forward and
# sideways up to 156 N (push_sideways_scale 0.23, above 1.5 x Table 6's 150 N), every 4 s, stopped
# at 180 M, on both seeds:
#   bcSM     seed 0
#   bcSM_s1  seed 1
# 200 M samples, pushes stopped at 180 M. Ran as calls of 547, 556 and 493 s wall (the last with
# PACK=policies and SECONDS 485): both runs ended in call C and were graded there.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
backflip="--clip backflip $push --set env.push_force_max_n=680 --set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bcSM|$backflip;grade_bcSM" \
  "bcSM_s1|$backflip --set run.seed=1;grade_bcSM_s1"
wait
