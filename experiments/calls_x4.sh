#!/usr/bin/env bash
# The device calls of 2026-11-26 on a lent four-GPU host, one run or bench lane per GPU
# (experiments/device_train.sh), after the warp-lang transfer and install:
#   bash experiments/calls_x4.sh 1 SECONDS   # new runs: mixed obstacles (issue 16); the three bench
#                                            # levels on flat and mixed, then the face-down getup
#                                            # with pushes (issue 14); strike and throw with both
#                                            # rewards (issue 15)
#   bash experiments/calls_x4.sh 2 SECONDS   # the same runs resumed, then the throw with the task
#                                            # reward only
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
S="--set physics.contacts_per_world=64 --set physics.constraints_per_world=320"
L="--preset gpu --num-envs 8192 --clip run --set task.name=heading $S"
T="--preset gpu --set env.pose_termination_m=1.0 --set run.eval_every=20000000 --set run.checkpoint_every=20000000 --set run.eval_episodes=100 --set run.total_samples=250000000"
G="--clip getup_facedown --preset gpu --set env.events=push --set env.push_force_max_n=400 --set env.push_interval_jitter_s=1.0 --set env.reset_noise_rad=0.3 --set run.total_samples=100000000 --set run.eval_every=20000000 --set run.checkpoint_every=20000000"
if [ "$1" = 1 ]; then
  bash experiments/device_train.sh "$2" \
    "run_mixed|--clip run --task heading --terrain mixed --preset gpu --set terrain.length_m=40 --set run.total_samples=200000000 $S" \
    "bench_flat3|$L;bench_mixed3|$L --terrain mixed --set terrain.length_m=40;getup_facedown_push|$G" \
    "strike_both|--clip spinkick --task strike $T" \
    "throw_both|--clip pitch --task throw $T"
else
  bash experiments/device_train.sh "$2" "run_mixed|" \
    "getup_facedown_push|;throw_task|--clip pitch --task throw $T --set task.imitation_weight=0 --set task.task_weight=1" \
    "strike_both|" "throw_both|"
fi
