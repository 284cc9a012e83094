#!/usr/bin/env bash
# The device calls of 2026-11-26 (fourth session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s6_x4.sh 1 SECONDS   # spin, getup_faceup, roll and cartwheel with the
#       # preset's 100 M (issue 13: their sim-to-sim), then four walk experts for the composite
#       # that start still, pushed or both (issue 14); best policies exported and brought back
#   bash experiments/calls_s6_x4.sh 2 SECONDS   # the G1 run with 200 M (issue 18), the strike's
#       # per-kick baselines (issue 15), the run with pushes up to 1.5 x Table 6 (issue 17),
#       # getups from noisier lying states (issue 14)
#   bash experiments/calls_s6_x4.sh 3 SECONDS   # those resumed; every policy brought back
# Run as: 1 550, 2 545, 3 230. g1_run200 stopped at once in call 2: the G1's MJCF (../shared/robots)
# is not on the device; carry a copy (an ignored folder) and point $MJXMIMIC_G1 at it.
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
w48="--clip walk --preset gpu --set run.total_samples=48000000"
still="--set env.reset_velocity_range=0,1"
push="--set env.events=push --set env.push_force_max_n=400 --set env.push_interval_jitter_s=1.0"
noise="--set env.reset_noise_rad=0.3"
strike="--clip spinkick --task strike --preset gpu --set task.target_each_cycle=true --set run.eval_every=20000000"
strike="$strike --set run.checkpoint_every=20000000 --set run.eval_episodes=100"
push1100="--set env.events=push --set env.push_force_max_n=1100 --set env.push_interval_jitter_s=1.0"
push1100="$push1100 --set env.friction_range=0.8,1.2 --set env.mass_range=0.9,1.1"
later=("g1_run200|--character g1 --clip run --preset gpu --set run.total_samples=200000000"
       "gfu_noise05|--clip getup_faceup --preset gpu $push --set env.reset_noise_rad=0.5"
       "gfd_noise03|--clip getup_facedown --preset gpu $noise")
case $1 in
  1) PACK=policies bash experiments/device_train.sh "$2" \
       "spin|--clip spin --preset gpu;walk_still|$w48 $still" \
       "getup_faceup|--clip getup_faceup --preset gpu;walk_push|$w48 $push $noise" \
       "roll|--clip roll --preset gpu;walk_still_push|$w48 $still $push $noise" \
       "cartwheel|--clip cartwheel --preset gpu;walk_still_noise|$w48 $still $noise" ;;
  2) mkdir -p /tmp/call1 && mv runs/* /tmp/call1/ 2>/dev/null
     PACK=none bash experiments/device_train.sh "$2" "${later[0]}" \
       "strike_imitation|$strike --set task.imitation_weight=1 --set task.task_weight=0;${later[1]}" \
       "strike_task|$strike --set task.imitation_weight=0 --set task.task_weight=1;${later[2]}" \
       "run_push1100|--clip run --preset gpu $push1100;walk_still_s1|$w48 $still --set run.seed=1" ;;
  3) mv /tmp/call1/walk_* runs/  # the four walks of call 1 had stopped at 31 to 40 M
     for n in strike_imitation strike_task run_push1100 walk_still_s1; do
       (XLA_PYTHON_CLIENT_PREALLOCATE=false python3 -m mjxmimic.cli export "runs/$n" >/dev/null 2>&1 \
         || echo "export $n failed") &
     done
     PACK=policies bash experiments/device_train.sh "$2" "${later[1]}" "${later[2]}" \
       "walk_still|$w48;walk_push|$w48" "walk_still_push|$w48;walk_still_noise|$w48" ;;
esac
