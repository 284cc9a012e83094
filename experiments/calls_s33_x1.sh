#!/usr/bin/env bash
# The device calls of 2026-11-29 (thirty-first session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s33_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s33_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: is seed 1's cost for the backflip's push training (bcSM_s1: 0.037 against b200_s1,
# whose 0.859 is above every push-trained backflip) the pushes' or the seed's? A third seed, the
# preset's backflip and bcSM's recipe side by side:
#   b200_s2   the preset, 200 M samples, no pushes (as b200 and b200_s1)
#   bcSM_s2   680 N forward and up to 156 N sideways, every 4 s, stopped at 180 M (as bcSM)
# Ran as calls of 548, 556 and 479 s wall (the last with PACK=policies and SECONDS 478): both runs
# ended in call C and were graded there.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
backflip="--clip backflip $push --set env.push_force_max_n=680 --set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "b200_s2|--clip backflip $long --set run.seed=2;grade_b200_s2" \
  "bcSM_s2|$backflip --set run.seed=2;grade_bcSM_s2"
wait
