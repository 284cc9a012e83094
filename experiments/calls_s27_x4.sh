#!/usr/bin/env bash
# The device calls of 2026-11-28 (twenty-fifth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s27_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s27_x4.sh SECONDS   # the last: every run's best policy back
# Issue 17. The run's stopped push training met its target on two seeds (rcF4Y); the same stop
# left the backflip (bcSY: costs 0.025, 0.028) and the cartwheel (ccR2Y: 0.028, 0.002) at one
# seed of two, and the spinkick's push training costs 0.044 on seed 1 (kcR_s1, 100 M). Each on
# both seeds, 200 M samples:
#   ccR2Z[_s1]   ccR2Y's settings with the pushes stopped at 160 M instead of 180 M: the
#                cartwheel recovered within 10 M of its stop; this gives it 40 M
#   bcSL[_s1]    bcSY's settings with the pushes starting at 100 M (env.push_start_samples), as
#                the run's do: the backflip learns the clip first
#   kcRY[_s1]    the spinkick's push training (kcR) for 200 M samples, pushes up to 1140 N
#                (about 10 % above 1.5 x Table 6, as the others) stopped at 180 M
#   k200[_s1]    the preset's spinkick for 200 M samples: kcRY's same-seed baselines
# Seed 1 first (where the costs were). Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000"
cartwheel="--clip cartwheel $push --set env.push_force_max_n=780 --set env.push_stop_samples=160000000"
backflip="--clip backflip $push --set env.push_sideways_scale=0.23 --set env.push_force_max_n=730 \
--set env.push_start_samples=100000000 --set env.push_stop_samples=180000000"
spinkick="--clip spinkick $push --set env.push_force_max_n=1140 --set env.push_stop_samples=180000000"
s1="--set run.seed=1"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "ccR2Z_s1|$cartwheel $s1;grade_ccR2Z_s1;ccR2Z|$cartwheel;grade_ccR2Z" \
  "bcSL_s1|$backflip $s1;grade_bcSL_s1;bcSL|$backflip;grade_bcSL" \
  "kcRY_s1|$spinkick $s1;grade_kcRY_s1;kcRY|$spinkick;grade_kcRY" \
  "k200_s1|--clip spinkick $long $s1;grade_k200_s1;k200|--clip spinkick $long;grade_k200"
