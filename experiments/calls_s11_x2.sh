#!/usr/bin/env bash
# The device calls of 2026-11-26 (ninth session) on a lent two-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh): issue 14's skill selector
# over walk, run and backflip trained with switches every 4 s on average (as `sw4`) that enter the
# new clip at its reference pose nearest the character's (env.skill_switch_entry=nearest), 500 M
# samples, seeds 1 (as `sw4`) and 2.
#   bash experiments/calls_s11_x2.sh 1 SECONDS   # both start; runs stay on the machine
#   bash experiments/calls_s11_x2.sh 2 SECONDS   # both go on; runs stay on the machine
#   bash experiments/calls_s11_x2.sh 3 SECONDS   # both go on; exported best policies back
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
selector="--clip skills3 --preset gpu --set env.observations=phase,root_height,bodies,skill"
selector="$selector --set run.total_samples=500000000 --set run.eval_every=20000000"
selector="$selector --set env.skill_switch_s=4 --set env.skill_switch_entry=nearest"
pack=none; [ "$1" = 3 ] && pack=best
PACK=$pack bash experiments/device_train.sh "$2" "sn1|$selector --set run.seed=1" \
  "sn2|$selector --set run.seed=2"
