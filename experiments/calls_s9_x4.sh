#!/usr/bin/env bash
# The device calls of 2026-11-26 (seventh session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s9_x4.sh 1 SECONDS   # issue 14: the skill selector over walk, run and
#       # backflip (200 M, and 300 M with seed 1); the max-of-clips reward over the walker clips,
#       # alone and with the target-heading task (100 M each)
#   bash experiments/calls_s9_x4.sh 2 SECONDS   # the selectors go on; then issue 15: the throw
#       # with task.throw_shape 2 and 8 at equal weights (250 M); issue 18: the dog's canter (it
#       # got 45 s and no samples before the call's end, and was dropped)
#   bash experiments/calls_s9_x4.sh 3 SECONDS   # all go on; every run's exported best policy back
#       # (finished runs return at once)
# Carried (ignored folder): .clips/ (DeepMimic's motions with walker/).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
selector="--clip skills3 --preset gpu --set env.observations=phase,root_height,bodies,skill"
sel200="sel200|$selector --set run.total_samples=200000000"
sel300="sel300|$selector --set run.total_samples=300000000 --set run.seed=1"
walker="--clip walker --preset gpu --set reward.combine=max --set run.total_samples=100000000"
throw="--task throw --preset gpu --set task.imitation_weight=0.5 --set task.task_weight=0.5"
throw="$throw --set run.total_samples=250000000 --set run.eval_every=20000000"
throw="$throw --set run.checkpoint_every=20000000 --set run.eval_episodes=100"
dog="--character dog3d --preset gpu"
case $1 in
  1) PACK=none bash experiments/device_train.sh "$2" "$sel200" "walker_max|$walker" \
       "walker_heading|$walker --task heading" "$sel300" ;;
  2) PACK=none bash experiments/device_train.sh "$2" "$sel200;dog_canter|$dog --clip canter" \
       "walker_max|$walker;throw_k2|$throw --set task.throw_shape=2" \
       "walker_heading|$walker --task heading;throw_k8|$throw --set task.throw_shape=8" "$sel300" ;;
  3) PACK=policies bash experiments/device_train.sh "$2" "$sel200" \
       "walker_max|$walker;throw_k2|$throw --set task.throw_shape=2" \
       "walker_heading|$walker --task heading;throw_k8|$throw --set task.throw_shape=8" \
       "$sel300" ;;
esac
