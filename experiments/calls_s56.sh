#!/usr/bin/env bash
# The next device block (issue 13, plan item 2), after the transfer and install of
# experiments/README.md ("device time"):
#   bash experiments/calls_s56.sh SECONDS        # calls A, B and C, the same command
# Whether 400 M samples make the backflip pass over the whole cycle on a second seed: seed 1 with
# 400 M (`bpK2_400_s1`) scores 0.750 and tracks at 0.773 on the starts that do not fall, against
# 0.76 with 200 M on seeds 0 and 1 (experiments/README.md, "The backflip with 400 M samples").
# `mjxmimic train --clip backflip --preset gpu --set run.total_samples=400000000` (seed 0),
# graded on MuJoCo C (no push tests) as it ends, resumed from call to call on the warm machine;
# on two GPUs the cartwheel on seed 1 (only seed 0 so far) beside it, on four the punch and the
# kick on seed 1 too (`--set run.seed=1` and nothing else).
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
gpus=$(nvidia-smi -L | wc -l)
lane() { echo "$1|--clip $2 --preset gpu ${*:3};grade_$1"; }  # NAME CLIP [ARGS...]
backflip=$(lane bpK2_400 backflip --set run.total_samples=400000000)
cartwheel=$(lane cartK2_s1 cartwheel --set run.seed=1)
if [ "$gpus" -ge 4 ]; then
  lanes=("@0 $backflip" "@1 $cartwheel" "@2 $(lane punchK2_s1 punch --set run.seed=1)"
         "@3 $(lane kickK2_s1 kick --set run.seed=1)")
elif [ "$gpus" -ge 2 ]; then
  lanes=("@0 $backflip" "@1 $cartwheel")
else
  lanes=("@0 $backflip")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
