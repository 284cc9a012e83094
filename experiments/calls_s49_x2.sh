#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-seventh session) on a lent two-H200 host, after the
# transfer and install of experiments/README.md ("device time"):
#   bash experiments/calls_s49_x2.sh SECONDS        # calls A, B and C, the same command
# One lane a GPU, each run graded on MuJoCo C (no push tests) as it ends, the runs resumed from
# call to call on the warm machine; issue 13, plan item 2: the spinkick with 200 M samples, as the
# roll, the backflip and dance_a have in the suite (at 100 M it passed Table 2 on three runs of
# four, all still rising), on seeds 0, 1 and 2; and the backflip with 200 M on today's preset
# again (bpK2 was stopped at 144 M by the forty-sixth session's last call, ungraded):
# - lane 0: the spinkick on seeds 0 and 2;
# - lane 1: the spinkick on seed 1, then the backflip.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
preset="--preset gpu --set run.total_samples=200000000"
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 spinkickK2|--clip spinkick $preset;grade_spinkickK2;spinkickK2_s2|--clip spinkick $preset --set run.seed=2;grade_spinkickK2_s2" \
  "@1 spinkickK2_s1|--clip spinkick $preset --set run.seed=1;grade_spinkickK2_s1;bpK2b|--clip backflip $preset;grade_bpK2b"
