#!/usr/bin/env bash
# The device block of 2026-12-01 (forty-ninth session; issue 13, plan item 2) on a lent one-H200
# host, which took the one-GPU branch below, after the transfer and install of
# experiments/README.md ("device time"):
#   bash experiments/calls_s51.sh SECONDS        # calls A, B and C, the same command
# The suite's clips whose entries still predate the preset's 200 M default, trained with
# `mjxmimic train --clip CLIP --preset gpu` and nothing else, seed 0, each graded on MuJoCo C (no
# push tests) as it ends, the runs resumed from call to call on the warm machine. On a four-GPU
# host: the getups, the kick and the crawl (100 M runs on today's preset), and the walk and the
# run (their entries predate the reference_root term and the KL stop). On a two-GPU host, the
# two lanes that fit a block: the getups, then the kick and the walk; on one GPU, the getups.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
gpus=$(nvidia-smi -L | wc -l)
lanes=("@0 getupK2b|--clip getup_faceup --preset gpu;grade_getupK2b;getupfdK2b|--clip getup_facedown --preset gpu;grade_getupfdK2b")
if [ "$gpus" -ge 4 ]; then
  lanes+=("@1 kickK2b|--clip kick --preset gpu;grade_kickK2b;crawlK2b|--clip crawl --preset gpu;grade_crawlK2b"
          "@2 walkK2|--clip walk --preset gpu;grade_walkK2"
          "@3 runK2|--clip run --preset gpu;grade_runK2")
elif [ "$gpus" -ge 2 ]; then
  lanes+=("@1 kickK2b|--clip kick --preset gpu;grade_kickK2b;walkK2|--clip walk --preset gpu;grade_walkK2")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
