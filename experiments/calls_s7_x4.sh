#!/usr/bin/env bash
# The device calls of 2026-11-26 (fifth session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s7_x4.sh 1 SECONDS   # getups that also start still (issue 14): the
#       # face-down one (seeds 0 and 1, and with reset noise) to 150 M, the face-up one with the
#       # composite's push settings; a walk expert of another seed
#   bash experiments/calls_s7_x4.sh 2 SECONDS   # the strike with equal imitation and task weights
#       # (issue 15), the G1 run with 200 M (issue 18), more composite experts
#   bash experiments/calls_s7_x4.sh 3 SECONDS   # those resumed; every policy brought back
# Run as: 1 550, 2 548, 3 455.
# The G1's MJCF travels in .g1/ (carried) and its retargeted run in .clips/g1_run.txt
# (`mjxmimic clips retarget run --to g1 --out .clips/g1_run.txt`).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips MJXMIMIC_G1=$PWD/.g1
still="--set env.reset_velocity_range=0,1"
gfd="--clip getup_facedown --preset gpu $still --set run.total_samples=150000000"
push="--set env.events=push --set env.push_force_max_n=400 --set env.push_interval_jitter_s=1.0"
walk30="--clip walk --preset gpu --set run.total_samples=30000000 $still --set env.reset_noise_rad=0.3"
strike="--clip spinkick --task strike --preset gpu --set task.target_each_cycle=true --set run.eval_every=20000000"
strike="$strike --set run.checkpoint_every=20000000 --set run.eval_episodes=100 --set run.total_samples=200000000"
strike="$strike --set task.imitation_weight=0.5 --set task.task_weight=0.5"
lanes=("gfd_still|$gfd"
       "gfd_still_s1|$gfd --set run.seed=1"
       "gfd_still_noise|$gfd --set env.reset_noise_rad=0.15"
       "gfu_still|--clip getup_faceup --preset gpu $push --set env.reset_noise_rad=0.3 $still;walk_wsn_s1|$walk30 --set run.seed=1")
later=("strike_w05|$strike"
       "g1_run200|--character g1 --clip run --preset gpu --set run.total_samples=200000000"
       "walk_wsn_s2|$walk30 --set run.seed=2;gfu_still_s1|--clip getup_faceup --preset gpu $push --set env.reset_noise_rad=0.3 $still --set run.seed=1"
       "gfd_still_push|$gfd $push")
case $1 in
  1) PACK=none bash experiments/device_train.sh "$2" "${lanes[@]}" ;;
  2) PACK=none bash experiments/device_train.sh "$2" "${later[@]}" ;;  # call 1's runs had all finished
  3) for n in gfd_still gfd_still_s1 gfd_still_noise gfu_still walk_wsn_s1; do  # finished in call 1
       (XLA_PYTHON_CLIENT_PREALLOCATE=false python3 -m mjxmimic.cli export "runs/$n" >/dev/null 2>&1 \
         || echo "export $n failed") &
     done
     PACK=policies bash experiments/device_train.sh "$2" "${later[@]}" ;;
esac
