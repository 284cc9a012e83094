#!/usr/bin/env bash
# The device calls of 2026-11-29 (thirty-third session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s35_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s35_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: the backflip's pushes stopped at 160 M (bcSN) cost less than at 180 M (bcSM) but lost
# the forward force off MJX-Warp (488 and 594 N on MuJoCo C against 660 N); with a push every 2 s
# and the stop at 180 M, pushes up to 730 N (bcSY) had kept 769 to 875 N there. Does the stop at
# 160 M keep the force with pushes up to 730 N forward (and up to 168 N sideways, scale 0.23)?
#   bcSO      730 N forward and up to 168 N sideways, every 4 s, stopped at 160 M, seed 0
#   bcSO_s1   the same, seed 1
# Ran as calls of 548, 541 and 434 s wall (the last with PACK=policies and SECONDS 500): both runs
# ended in call C and were graded there in full, on MJX-Warp and MuJoCo C.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=160000000"
backflip="--clip backflip $push --set env.push_force_max_n=730 --set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bcSO|$backflip;grade_bcSO" \
  "bcSO_s1|$backflip --set run.seed=1;grade_bcSO_s1"
wait
