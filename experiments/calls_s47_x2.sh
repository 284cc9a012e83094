#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-fifth session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"):
#   bash experiments/calls_s47_x2.sh SECONDS        # calls A, B and C, the same command
# One lane a GPU, each run graded on MuJoCo C (no push tests) as it ends, the runs resumed from
# call to call on the warm machine; issue 13, plan item 2:
# - lane 0: the jump with 400 M samples, about as many as issue 13's 20 minutes of H200 time
#   hold (it reached 0.861 with 200 M against Table 2's 0.947, still rising);
# - lane 1: the roll on seeds 1 and 2 with 200 M samples (seed 0 ended 0.021 below its best:
#   does its end swing past issue 13's 0.02 again?).
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
preset="--preset gpu"
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 jumpK4|--clip jump $preset --set run.total_samples=400000000;grade_jumpK4" \
  "@1 rollK2_s1|--clip roll $preset --set run.total_samples=200000000 --set run.seed=1;grade_rollK2_s1;rollK2_s2|--clip roll $preset --set run.total_samples=200000000 --set run.seed=2;grade_rollK2_s2"
