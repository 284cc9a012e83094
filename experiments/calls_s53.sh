#!/usr/bin/env bash
# The device block of 2026-12-01 (fifty-first session; issue 13, plan item 2) on a lent one-H200
# host, which took the one-GPU branch below, after the transfer and install of
# experiments/README.md ("device time"):
#   bash experiments/calls_s53.sh SECONDS        # calls A, B and C, the same command
# The last two of the suite's clips whose entries predate the preset as it stands, trained with
# `mjxmimic train --clip CLIP --preset gpu` and nothing else, seed 0, each graded on MuJoCo C (no
# push tests) as it ends, the runs resumed from call to call on the warm machine: the crawl (a
# 100 M run on today's preset) and the run (its entry predates the reference_root term and the
# KL stop). One run a GPU on two GPUs; on four, second seeds of the walk and the run beside them;
# the crawl and then the run on one.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
gpus=$(nvidia-smi -L | wc -l)
crawl="crawlK2b|--clip crawl --preset gpu;grade_crawlK2b"
run="runK2|--clip run --preset gpu;grade_runK2"
if [ "$gpus" -ge 4 ]; then
  lanes=("@0 $crawl" "@1 $run" "@2 walkK2_s1|--clip walk --preset gpu --set run.seed=1;grade_walkK2_s1"
         "@3 runK2_s1|--clip run --preset gpu --set run.seed=1;grade_runK2_s1")
elif [ "$gpus" -ge 2 ]; then
  lanes=("@0 $crawl" "@1 $run")
else
  lanes=("@0 $crawl;$run")
fi
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" "${lanes[@]}"
