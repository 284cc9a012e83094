#!/usr/bin/env bash
# The next device block (issue 13, plan item 2), after the transfer and install of
# experiments/README.md ("device time"):
#   bash experiments/calls_s52.sh SECONDS        # calls A, B and C, the same command
# The suite's clips whose entries still predate the preset as it stands, trained with
# `mjxmimic train --clip CLIP --preset gpu` and nothing else, seed 0, each graded on MuJoCo C (no
# push tests) as it ends, the runs resumed from call to call on the warm machine: the kick and the
# crawl (100 M runs on today's preset), the walk and the run (their entries predate the
# reference_root term and the KL stop). One run a GPU on a four-GPU host, two a GPU on two (the
# kick, then the walk; the crawl, then the run), the kick and then the walk on one.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
gpus=$(nvidia-smi -L | wc -l)
if [ "$gpus" -ge 4 ]; then
  lanes=("@0 kickK2b|--clip kick --preset gpu;grade_kickK2b" "@1 crawlK2b|--clip crawl --preset gpu;grade_crawlK2b"
         "@2 walkK2|--clip walk --preset gpu;grade_walkK2" "@3 runK2|--clip run --preset gpu;grade_runK2")
else
  lanes=("@0 kickK2b|--clip kick --preset gpu;grade_kickK2b;walkK2|--clip walk --preset gpu;grade_walkK2")
  [ "$gpus" -ge 2 ] && lanes+=("@1 crawlK2b|--clip crawl --preset gpu;grade_crawlK2b;runK2|--clip run --preset gpu;grade_runK2")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
