#!/usr/bin/env bash
# The device calls of 2026-11-26 (tenth session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s12_x4.sh 1 SECONDS   # all start; runs stay on the machine
#   bash experiments/calls_s12_x4.sh 2 SECONDS   # all go on; runs stay on the machine
#   bash experiments/calls_s12_x4.sh 3 SECONDS   # all go on; every run's exported best policy back
# Lanes 1 and 2, issue 14: the skill selector over walk, run and backflip as `sn2` (switches about
# every 4 s into the new clip's nearest reference pose) with the settle window
# (env.skill_switch_settle_s=1), 400 M samples, seeds 2 and 1.
# Lanes 3 and 4, issue 17: pushes along the character's facing in training
# (env.push_directions=table6), 100 M samples each: the run with pushes up to 1.5 x and 1 x Table
# 6's forward 720 N, then the backflip and the spinkick up to 1.5 x theirs (440 and 690 N).
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
selector="--clip skills3 --preset gpu --set env.observations=phase,root_height,bodies,skill"
selector="$selector --set run.total_samples=400000000 --set run.eval_every=20000000"
selector="$selector --set env.skill_switch_s=4 --set env.skill_switch_entry=nearest"
selector="$selector --set env.skill_switch_settle_s=1"
push="--preset gpu --set env.events=push --set env.push_directions=table6"
push="$push --set env.push_interval_jitter_s=1.0 --set run.total_samples=100000000"
pack=none; [ "$1" = 3 ] && pack=policies
PACK=$pack bash experiments/device_train.sh "$2" "st2|$selector --set run.seed=2" \
  "st1|$selector --set run.seed=1" \
  "rt1080|--clip run $push --set env.push_force_max_n=1080;bt660|--clip backflip $push --set env.push_force_max_n=660" \
  "rt720|--clip run $push --set env.push_force_max_n=720;kt1035|--clip spinkick $push --set env.push_force_max_n=1035"
