#!/usr/bin/env bash
# The device calls of 2026-11-27 (sixteenth session) on a lent two-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s18_x2.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s18_x2.sh SECONDS   # the last: every run's best policy back
# The questions (issue 17):
# 1. The preset's cartwheel without pushes for 200 M samples (c200), so that the cartwheel's 200 M
#    push run (ccR2, NR 0.900) is costed at the same budget, as the run and the backflip are.
# 2. The run's push training with the pushes held back until the policy has learned the clip
#    (env.push_start_samples): rcR2's pushes (up to 1080 N along the facing or to the sides, root
#    frame; NR cost 0.054 against the preset's 200 M run, r200, 0.910) from 100 M samples on,
#    ramped over 50 M (rcL); the same with a push every 4 to 5 s instead of 2 to 3 s (rcL4); and
#    from 150 M on, ramped over 25 M (rcL150).
# Ran as: calls A (530 s, with the install; 547 s wall), B (570; stopped by the device's 600 s limit
# while grading, graded again in C) and C (PACK=policies, 473; 433 s wall) on two H200s; records in
# experiments/robustness/late/. rcL kept its 100 M checkpoint (before any push) as its best: the
# loop has kept the best only from the full pushes on since.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_force_max_n=1080"
late="$push --set env.push_start_samples=100000000 --set env.push_ramp_samples=50000000"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "c200|--clip cartwheel $long;grade_c200;rcL150|--clip run $push --set env.push_start_samples=150000000 --set env.push_ramp_samples=25000000;grade_rcL150" \
  "rcL|--clip run $late;grade_rcL;rcL4|--clip run $late --set env.push_interval_s=4;grade_rcL4"
