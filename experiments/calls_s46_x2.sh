#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-fourth session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"):
#   bash experiments/calls_s46_x2.sh SECONDS        # calls A, B and C, the same command
# One lane a GPU, each run graded on MuJoCo C (no push tests) as it ends, the runs resumed from
# call to call on the warm machine:
# - issue 18, plan item 5: the dog's trot, pace and canter on today's `gpu` preset (the paper form
#   as written with reference_root and the KL stop; last trained on it without the term);
# - issue 13: second seeds of the two looping clips nearest Table 2 on the preset (dance_b 0.832
#   against 0.822, the spinkick 0.760 against 0.748), to show whether seed 0's pass repeats.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
preset="--preset gpu"
dog="--character dog3d"
seed1="--set run.seed=1"
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 dtK|$dog --clip trot $preset;grade_dtK;dcK|$dog --clip canter $preset;grade_dcK" \
  "@1 dpK|$dog --clip pace $preset;grade_dpK;dancebK_s1|--clip dance_b $preset $seed1;grade_dancebK_s1;spinkickK_s1|--clip spinkick $preset $seed1;grade_spinkickK_s1"
