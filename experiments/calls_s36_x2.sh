#!/usr/bin/env bash
# The second device block of 2026-11-29 (thirty-fourth session) on one lent H200, after the
# warp-lang transfer and install again (the host of calls_s36_x1.sh went back, idle, after its
# first call, with every run on it), two lanes sharing the GPU (experiments/device_train.sh), each
# run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s36_x2.sh SECONDS                 # the first call; the runs stay there
#   PACK=policies bash experiments/calls_s36_x2.sh SECONDS   # the last: every run's best policy back
# Issue 17: fine-tuned from b200_s2 (NR 0.867) with pushes ramped over 10 M and stopped at 30 M
# (ftP, calls_s36_x1.sh), the backflip kept its NR (0.869 at 15 M, 0.865 at 40 M) but its best
# checkpoint, at 15 M after 5 M of full pushes, took 225 N forward (the source 200 N). Longer:
# 80 M samples, pushes ramped over 40 M (no checkpoint before 40 M is kept as the best) and
# stopped at 70 M, bcSM's pushes otherwise, at two learning rates (fresh optimiser):
#   ftR   cosine 1e-4 -> 3e-5          ftS   cosine 3e-4 -> 3e-5 (the preset's schedule)
# Ran as calls of 519 s (SECONDS 495) and 311 s wall (PACK=policies, SECONDS 420) after fourteen
# transfer calls: both runs ended in the second call and were graded there in full.
# Carried (ignored folders): .clips/ (DeepMimic's motions), .data/b200_s2.npz.
set -u
tune="--clip backflip --preset gpu --init-from .data/b200_s2.npz --set run.seed=2 \
--set run.total_samples=80000000 --set run.eval_every=5000000 --set ppo.learning_rate_schedule=cosine \
--set ppo.learning_rate_final=3e-5 --set env.pose_termination_frame=root --set env.events=push \
--set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=40000000 \
--set env.push_stop_samples=70000000 --set env.push_force_max_n=680 --set env.push_sideways_scale=0.23 \
--set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "ftR|$tune --set ppo.learning_rate=1e-4;grade_ftR" \
  "ftS|$tune --set ppo.learning_rate=3e-4;grade_ftS"
wait
