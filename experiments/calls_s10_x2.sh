#!/usr/bin/env bash
# The device calls of 2026-11-26 (eighth session) on a lent two-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh): issue 14's skill selector
# over walk, run and backflip trained with switches (env.skill_switch_s; a one-off clip entered
# where a cycle ends and left at its end), every 2 s and every 4 s on average, 300 M samples.
#   bash experiments/calls_s10_x2.sh 1 SECONDS   # both start; runs stay on the machine
#   bash experiments/calls_s10_x2.sh 2 SECONDS   # both go on; every run's exported best policy back
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
selector="--clip skills3 --preset gpu --set env.observations=phase,root_height,bodies,skill"
selector="$selector --set run.total_samples=300000000 --set run.seed=1 --set run.eval_every=20000000"
case $1 in
  1) PACK=none bash experiments/device_train.sh "$2" "sw2|$selector --set env.skill_switch_s=2" \
       "sw4|$selector --set env.skill_switch_s=4" ;;
  2) PACK=policies bash experiments/device_train.sh "$2" "sw2|$selector --set env.skill_switch_s=2" \
       "sw4|$selector --set env.skill_switch_s=4" ;;
esac
