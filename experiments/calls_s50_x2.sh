#!/usr/bin/env bash
# The device block of 2026-12-01 (forty-eighth session) on a lent two-H200 host, after the
# transfer and install of experiments/README.md ("device time"):
#   bash experiments/calls_s50_x2.sh SECONDS        # calls A, B and C, the same command
# One lane a GPU, each run graded on MuJoCo C (no push tests) as it ends, the runs resumed from
# call to call on the warm machine; issue 13, plan item 2: clips that pass Table 2 at 100 M,
# trained with the preset's default of 200 M since the forty-seventh session and nothing else,
# seed 0; first the four whose suite entries predate the KL stop:
# - lane 0: dance_b (the thinnest of the seven, 0.010 over Table 2), then the spin;
# - lane 1: the punch, then the cartwheel.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 dancebK2|--clip dance_b --preset gpu;grade_dancebK2;spinK2|--clip spin --preset gpu;grade_spinK2" \
  "@1 punchK2|--clip punch --preset gpu;grade_punchK2;cartK2|--clip cartwheel --preset gpu;grade_cartK2"
