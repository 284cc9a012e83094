#!/usr/bin/env bash
# The device calls of 2026-11-27 (fifteenth session) on a lent two-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s17_x2.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s17_x2.sh SECONDS   # the last: every run's best policy back
# The questions (issue 17):
# 1. The run and the backflip with pushes and the root frame for 200 M samples, as rcR2 and bcR2
#    of calls_s16_x4.sh (NR costs 0.038 and 0.027 against the preset's 100 M policies, target
#    0.02), but with their sideways pushes scaled to stop at 1.5 x Table 6's sideways force
#    (env.push_sideways_scale: run 0.42 x 1080 N = 454 N >= 450 N, backflip 0.23 x 660 N = 152 N
#    >= 150 N) instead of the forward one.
# 2. The preset's run and backflip without pushes for 200 M samples, so that the NR cost of a
#    200 M push run is measured at the same budget.
# Ran as: calls A (530 s, with the install; 548 s wall), B (570; 587 s wall) and C (PACK=policies,
# 489; 465 s wall) on two H200s; records in experiments/robustness/sideways/.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rcS|--clip run $push --set env.push_force_max_n=1080 --set env.push_sideways_scale=0.42;grade_rcS;r200|--clip run $long;grade_r200" \
  "bcS|--clip backflip $push --set env.push_force_max_n=660 --set env.push_sideways_scale=0.23;grade_bcS;b200|--clip backflip $long;grade_b200"
