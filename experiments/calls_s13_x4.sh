#!/usr/bin/env bash
# The device calls of 2026-11-27 (eleventh session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s13_x4.sh 1 SECONDS   # all start; runs stay on the machine
#   bash experiments/calls_s13_x4.sh 2 SECONDS   # all go on; runs stay on the machine
#   bash experiments/calls_s13_x4.sh 3 SECONDS   # all go on; the exported best policies back
# The question: how far the paper form as written (reward.kind=paper, DEEPMIMIC.md) gets when a
# policy trains on it, against the same runs trained on the released form. 100 M samples each.
# Lane 1: walk, run and backflip trained on the paper form as written (issue 13).
# Lane 2: the same three with the preset as it is (released form), kept this time (issues 13, 14).
# Lane 3: the max-of-clips walker with the heading task (issue 14), then the dog's trot (issue
# 18), both on the paper form as written. Lane 4: the dog's pace and canter, likewise.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
paper="--preset gpu --set reward.kind=paper"
dog="--character dog3d $paper"
lane1="wp|--clip walk $paper;rp|--clip run $paper;bp|--clip backflip $paper"
lane2="w100|--clip walk --preset gpu;r100|--clip run --preset gpu;b100|--clip backflip --preset gpu"
lane3="whp|--clip walker --task heading --set reward.combine=max $paper;dtp|--clip trot $dog"
lane4="dpp|--clip pace $dog;dcp|--clip canter $dog"
pack=none; [ "$1" = 3 ] && pack=policies
PACK=$pack bash experiments/device_train.sh "$2" "$lane1" "$lane2" "$lane3" "$lane4"
