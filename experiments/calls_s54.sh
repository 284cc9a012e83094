#!/usr/bin/env bash
# The device block of 2026-12-01 (fifty-second session; issue 13, plan item 2) on a lent one-H200
# host, which took the one-GPU branch below, after the transfer and install of
# experiments/README.md ("device time"):
#   bash experiments/calls_s54.sh SECONDS        # calls A, B and C, the same command
# Second seeds, on the preset as it stands, of suite passes that have only seed 0 there, as the
# judge re-measures a sample of clips: `mjxmimic train --clip CLIP --preset gpu --set
# run.seed=1` and nothing else, each graded on MuJoCo C (no push tests) as it ends, the runs
# resumed from call to call on the warm machine. The backflip (the pass nearest Table 2 of those)
# and the spin (3 of 64 episodes fallen in its last evaluations); on four GPUs the cartwheel and
# the punch beside them; one run a GPU on two; the backflip and then the spin on one.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
gpus=$(nvidia-smi -L | wc -l)
seed1() { echo "$1|--clip $2 --preset gpu --set run.seed=1;grade_$1"; }
backflip=$(seed1 bpK2_s1 backflip)
spin=$(seed1 spinK2_s1 spin)
if [ "$gpus" -ge 4 ]; then
  lanes=("@0 $backflip" "@1 $spin" "@2 $(seed1 cartK2_s1 cartwheel)" "@3 $(seed1 punchK2_s1 punch)")
elif [ "$gpus" -ge 2 ]; then
  lanes=("@0 $backflip" "@1 $spin")
else
  lanes=("@0 $backflip;$spin")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
