#!/usr/bin/env bash
# The device calls of 2026-11-28 (twenty-second session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s24_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s24_x4.sh SECONDS   # the last: every run's best policy back
# Issue 17. Two new ideas to keep the run's NR under push training, each on seed 1, where rcF4's
# settings cost 0.065 against rF200_s1 and 0.049 against r200_s1 (200 M samples each):
#   rcF4X_s1  rcF4_s1 with the pushes stopped at 180 M samples (env.push_stop_samples): the last
#             20 M train on the clip alone, as it is graded
#   rcF4H_s1  rcF4_s1 with half of the episodes pushed (env.push_episode_share=0.5)
# and second seeds of the claims that rest on one seed, with their same-seed baselines:
#   bcS_s1    the backflip's push training (seed 0: cost 0.009 against b200), 200 M
#   b200_s1   the preset's backflip, 200 M
#   kcR_s1    the spinkick's push training (seed 0: cost 0.009 against the preset's 100 M), 100 M
#   k100_s1   the preset's spinkick, 100 M
#   bF25_s1   the backflip without pushes on a fixed std of 0.25 (seed 0: 562 / 325 N), 100 M
# and the spinkick without pushes on a fixed std of 0.2, its preset's starting std (sF20, 100 M;
# on 0.15 it learned worse, sF15).
# Ran as: calls A (530 s, with the install; 548 s wall), B (530; 559 s) and C (PACK=policies,
# 440; 475 s) on four H200s (asked for as nvidia-h200-x4). Call C packed the policies before every
# MuJoCo C test had run: the NRs on MuJoCo C of all eight runs and the push tests of bF25_s1,
# kcR_s1 and sF20 ran on a 2-core CPU machine afterwards.
# Records in experiments/robustness/push_share_stop/, second_seed/ and fixed_std/.
# Seed 0 unless named. Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
fixed="--preset gpu --set ppo.std_mode=fixed --set ppo.init_action_std"
long="--set run.total_samples=200000000"
short="--set run.total_samples=100000000"
pushes="--set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000"
run_push="--clip run $fixed=0.15 $long $pushes --set env.push_start_samples=100000000 \
--set env.push_force_max_n=1080 --set env.push_interval_s=4"
backflip_push="--clip backflip --preset gpu $long --set env.events=push --set env.push_directions=table6 \
--set env.push_sideways_scale=0.23 --set env.push_force_max_n=660 --set env.push_interval_jitter_s=1.0 \
--set env.push_ramp_samples=50000000"
spinkick_push="--clip spinkick --preset gpu $short $pushes --set env.push_force_max_n=1035"
s1="--set run.seed=1"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rcF4X_s1|$run_push --set env.push_stop_samples=180000000 $s1;grade_rcF4X_s1;kcR_s1|$spinkick_push $s1;grade_kcR_s1" \
  "rcF4H_s1|$run_push --set env.push_episode_share=0.5 $s1;grade_rcF4H_s1;k100_s1|--clip spinkick --preset gpu $short $s1;grade_k100_s1" \
  "bcS_s1|$backflip_push $s1;grade_bcS_s1;bF25_s1|--clip backflip $fixed=0.25 $short $s1;grade_bF25_s1" \
  "b200_s1|--clip backflip --preset gpu $long $s1;grade_b200_s1;sF20|--clip spinkick $fixed=0.2 $short;grade_sF20"
