#!/usr/bin/env bash
# The device calls of 2026-11-28 (twenty-fourth session) on a lent two-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s26_x2.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s26_x2.sh SECONDS   # the last: every run's best policy back
# Issue 17. The run met the push-training target on two seeds once its pushes stopped at 0.9 of
# its samples and went a little above 1.5 x Table 6 (rcF4Y, rcF4Y_s1). The same change for the
# backflip (bcS: 0.009 seed 0, 0.041 seed 1) and the cartwheel (ccR2: 0.017, 0.067), on both
# seeds, 200 M samples each:
#   bcSY[_s1]    bcS's settings, pushes stopped at 180 M, up to 730 N instead of 660 N
#   ccR2Y[_s1]   ccR2's settings, pushes stopped at 180 M, up to 780 N instead of 705 N
# Seed 1 first (where the costs were). Carried (ignored folder): .clips/ (DeepMimic's motions).
# Ran as: calls A (530 s, with the install; 548 s wall), B (530; 557 s) and C (PACK=policies, 500;
# 526 s) on two H200s (asked for as nvidia-h200-x2). The cartwheels ended in call C with time for
# their MJX push test only: their MuJoCo C tests ran on a 2-core CPU machine afterwards.
# Records in experiments/robustness/push_share_stop/.
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
push="--preset gpu --set run.total_samples=200000000 --set env.pose_termination_frame=root --set env.events=push \
--set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 \
--set env.push_stop_samples=180000000"
backflip="--clip backflip $push --set env.push_sideways_scale=0.23 --set env.push_force_max_n=730"
cartwheel="--clip cartwheel $push --set env.push_force_max_n=780"
s1="--set run.seed=1"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bcSY_s1|$backflip $s1;grade_bcSY_s1;ccR2Y_s1|$cartwheel $s1;grade_ccR2Y_s1" \
  "bcSY|$backflip;grade_bcSY;ccR2Y|$cartwheel;grade_ccR2Y"
