#!/usr/bin/env bash
# The device calls of 2026-11-27/28 (nineteenth session) on a lent two-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s21_x2.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s21_x2.sh SECONDS   # the last: every run's best policy back
# Two questions of issue 17:
#   rsW    (GPU 0) the run's push training with the preset's world-frame pose termination and a
#          1 s settle window after each push (env.push_settle_s): rcL3L's pushes (a push every 3
#          to 4 s from 100 M samples, up to 1080 N, ramped over 50 M), 300 M samples, seed 0;
#          against r300 (no pushes, 0.909), where rcL3L (the same in the root frame) cost 0.041
#   rF15, rF30 (GPU 1) Table 6 without push training: the run with a
#          fixed exploration std of 0.15 and 0.3 rad, 100 M samples, seed 0; against r100
#          (learned std, 262 / 338 N on MuJoCo C)
# Ran as: calls A (530 s, with the install; 553 s wall), B (560; 572 s) and C (PACK=policies, 536;
# 29 s: nothing left to train) on two H200s. Calls A and B ran this file as first committed, with
# the spinkick (sF15, fixed std 0.15) after rF30 in the second lane and GRADE_MIN unset (150 s):
# B trained sF15 to 73 M samples. It was taken out (and GRADE_MIN set) to fit the block's device
# time, which call C ran, so sF15 stopped there, ungraded. Records in
# experiments/robustness/world_settle/ and fixed_std/.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
settle="--clip run --preset gpu --set run.total_samples=300000000 --set run.eval_every=20000000 \
--set env.pose_termination_frame=world --set env.push_settle_s=1.0 --set env.events=push \
--set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 --set env.push_start_samples=100000000 \
--set env.push_ramp_samples=50000000 --set env.push_force_max_n=1080 --set env.push_interval_s=3"
fixed="--preset gpu --set run.total_samples=100000000 --set ppo.std_mode=fixed"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rsW|$settle;grade_rsW" \
  "rF15|--clip run $fixed --set ppo.init_action_std=0.15;grade_rF15;rF30|--clip run $fixed --set ppo.init_action_std=0.3;grade_rF30"
