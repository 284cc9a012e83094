#!/usr/bin/env bash
# The device calls of 2026-11-26 (third session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s5_x4.sh 1 SECONDS   # crawl and getup_facedown with 200 M samples
#       # (issue 13), the run over mixed obstacles with an 8 x 8 heightmap at 0.2 m (issue 16), the
#       # strike with a new target at each kick cycle (issue 15)
#   bash experiments/calls_s5_x4.sh 2 SECONDS   # the same runs resumed, then the flat and
#       # mixed-obstacle benches with the 8 x 8 map; the best policies exported and brought back
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
S="--set physics.contacts_per_world=64 --set physics.constraints_per_world=320"
h8="--set terrain.heightmap_shape=8,8 --set terrain.heightmap_spacing_m=0.2"
n200="--preset gpu --set run.total_samples=200000000"
b="--preset gpu --num-envs 8192 --clip run --set task.name=heading --kinds train_loop $S $h8"
m="--terrain mixed --set terrain.length_m=40"
strike="--set task.target_each_cycle=true --set run.eval_every=20000000 --set run.checkpoint_every=20000000"
strike="$strike --set run.eval_episodes=100"
lanes=("crawl200|--clip crawl $n200" "getup_facedown200|--clip getup_facedown $n200"
       "run_mixed8|--clip run --task heading $m $n200 $h8 $S"
       "strike_cycle|--clip spinkick --task strike $n200 $strike")
case $1 in
  1) PACK=none bash experiments/device_train.sh "$2" "${lanes[@]}" ;;
  2) PACK=policies bash experiments/device_train.sh "$2" "${lanes[0]};bench_flat8|$b" \
       "${lanes[1]};bench_mixed8|$b $m" "${lanes[2]}" "${lanes[3]}" ;;
esac
