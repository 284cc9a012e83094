#!/usr/bin/env bash
# The device block of 2026-12-01 (fiftieth session; issue 13, plan item 2) on a lent one-H200
# host, which took the one-GPU branch below, after the transfer and install of
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
kick="kickK2b|--clip kick --preset gpu;grade_kickK2b"
crawl="crawlK2b|--clip crawl --preset gpu;grade_crawlK2b"
walk="walkK2|--clip walk --preset gpu;grade_walkK2"
run="runK2|--clip run --preset gpu;grade_runK2"
if [ "$gpus" -ge 4 ]; then
  lanes=("@0 $kick" "@1 $crawl" "@2 $walk" "@3 $run")
else
  lanes=("@0 $kick;$walk")
  [ "$gpus" -ge 2 ] && lanes+=("@1 $crawl;$run")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
