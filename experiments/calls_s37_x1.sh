#!/usr/bin/env bash
# The device block of 2026-11-29 (thirty-fifth session) on one lent H200, after the warp-lang
# transfer and install, two lanes sharing the GPU (experiments/device_train.sh), two runs a lane:
#   bash experiments/calls_s37_x1.sh SECONDS                 # the first calls; the runs stay there
#   PACK=policies bash experiments/calls_s37_x1.sh SECONDS   # the last: every run's best policy back
# Issue 13: how many of the suite's clips reach Table 2 in the paper form as written when trained
# on it (`reward.kind=paper`; "Training on the paper form as written": the walk, run and backflip
# did not). Four clips whose Table 2 NR lies far below what a character on the reference pose
# could score in that form (experiments/paper_form/reference_velocity_suite.json): spin (0.664,
# bound 0.945), roll (0.735, 0.945), getup_faceup (0.838, 0.984) and cartwheel (0.804, 0.974).
# The gpu preset otherwise, 100 M samples, seed 0; no grades here (MuJoCo C on the CPU machine).
# Ran as calls of 550 s (SECONDS 520), 211 s (525), 556 s (535) and 104 s (PACK=policies, 250)
# after fourteen transfer calls. The second call carried no .clips, so getupP and cartP stopped at
# once with "unknown clip" (spinP and rollP resumed from their own copies and ended there); they
# started in the third call and ended in the fourth. No grades on the GPU.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
paper="--preset gpu --set reward.kind=paper"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "spinP|--clip spin $paper;getupP|--clip getup_faceup $paper" \
  "rollP|--clip roll $paper;cartP|--clip cartwheel $paper"
wait
