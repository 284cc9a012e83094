#!/usr/bin/env bash
# The device calls of 2026-11-28 (twentieth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s22_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s22_x4.sh SECONDS   # the last: every run's best policy back
# Issue 17, with a fixed exploration std (ppo.std_mode=fixed), which took the run from 262 to
# 556 N forward without pushes at no NR cost (rF15, 100 M samples):
#   rcF4, rcF3  the run's push training on a fixed std of 0.15: rcL4's pushes (a push every 4 to
#               5 s from 100 M samples, ramped over 50 M, up to 1080 N; learned std: 706 N forward
#               on MuJoCo C at a cost of 0.012) and rcL3's (every 3 to 4 s: 1038 N at 0.024),
#               200 M samples, against r200 (0.910) and rF200
#   rF200       the run on a fixed std of 0.15 without pushes, 200 M samples
#   cF15        Table 6 without push training: the cartwheel on a fixed std of 0.15 (the
#               preset's 100 M cartwheel has 331 / 281 N against Table 6's 200 / 470 N), 100 M
#   rF15_s1     rF15's second seed
#   bF20, rF20, cF20  the backflip, the run and the cartwheel on a fixed std of 0.2, 100 M, where
#               their lanes have time left
# Ran as: calls A (530 s, with the install; 548 s wall), B (560; 588 s) and C (PACK=policies,
# 459; 322 s) on four H200s (asked for as nvidia-h100-x4). Records in
# experiments/robustness/fixed_std/.
# Seed 0 unless named. Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
fixed="--preset gpu --set ppo.std_mode=fixed --set ppo.init_action_std"
push="--clip run $fixed=0.15 --set run.total_samples=200000000 --set env.pose_termination_frame=root \
--set env.events=push --set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 \
--set env.push_start_samples=100000000 --set env.push_ramp_samples=50000000 --set env.push_force_max_n=1080"
short="--set run.total_samples=100000000"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rcF4|$push --set env.push_interval_s=4;grade_rcF4;bF20|--clip backflip $fixed=0.2 $short;grade_bF20" \
  "rcF3|$push --set env.push_interval_s=3;grade_rcF3;rF20|--clip run $fixed=0.2 $short;grade_rF20" \
  "rF200|--clip run $fixed=0.15 --set run.total_samples=200000000;grade_rF200;cF20|--clip cartwheel $fixed=0.2 $short;grade_cF20" \
  "cF15|--clip cartwheel $fixed=0.15 $short;grade_cF15;rF15_s1|--clip run $fixed=0.15 $short --set run.seed=1;grade_rF15_s1"
