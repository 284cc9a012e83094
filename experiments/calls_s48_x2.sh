#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-sixth session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"):
#   bash experiments/calls_s48_x2.sh SECONDS        # calls A, B and C, the same command
# One lane a GPU, each run graded on MuJoCo C (no push tests) as it ends, the runs resumed from
# call to call on the warm machine; issue 13, plan item 2: the passes with the thinnest margins
# over Table 2, on today's preset (KL stop) and other seeds:
# - lane 0: the spinkick on seed 1 again (its first run's policy never came back for the MuJoCo C
#   grade) and seed 2, dance_b on seed 2, then the backflip on today's preset (bpRR2 predates
#   the KL stop);
# - lane 1: dance_a with 200 M samples on today's preset, seeds 0 and 1 (danceaRR2 passed by
#   0.005 before the KL stop).
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
preset="--preset gpu"
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 spinkickK_s1b|--clip spinkick $preset --set run.seed=1;grade_spinkickK_s1b;dancebK_s2|--clip dance_b $preset --set run.seed=2;grade_dancebK_s2;spinkickK_s2|--clip spinkick $preset --set run.seed=2;grade_spinkickK_s2;bpK2|--clip backflip $preset --set run.total_samples=200000000;grade_bpK2" \
  "@1 danceaK2|--clip dance_a $preset --set run.total_samples=200000000;grade_danceaK2;danceaK2_s1|--clip dance_a $preset --set run.total_samples=200000000 --set run.seed=1;grade_danceaK2_s1"
