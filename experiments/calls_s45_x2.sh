#!/usr/bin/env bash
# The device block of 2026-11-30 (forty-third session) on a lent two-H200 host, after the transfer
# and install of experiments/README.md ("device time"):
#   bash experiments/calls_s45_x2.sh SECONDS        # calls A, B and C, the same command
# Issue 13 on today's `gpu` preset, one lane a GPU, each run graded on MuJoCo C (16 episodes, no
# push tests) as it ends, the runs resumed from call to call on the warm machine:
# - plan item 2(b): the getups (100 M, the preset's budget) and the roll (200 M), last trained on the
#   preset before the reference_root term and the KL stop, to show that today's preset keeps them;
# - 2(c): the jump with 200 M samples (0.843 at 100 M, still rising);
# - 2(d): the crawl and the jump with central-difference reference velocities (100 M each).
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
preset="--preset gpu"
run200="--set run.total_samples=200000000"
central="--set clip.velocity=central"
GRADE_PUSH=0 PACK=none bash experiments/device_train.sh "$1" \
  "@0 getupfdK2|--clip getup_facedown $preset;grade_getupfdK2;getupK2|--clip getup_faceup $preset;grade_getupK2;jumpK2|--clip jump $preset $run200;grade_jumpK2" \
  "@1 rollK2|--clip roll $preset $run200;grade_rollK2;crawlC|--clip crawl $preset $central;grade_crawlC;jumpC|--clip jump $preset $central;grade_jumpC"
