#!/usr/bin/env bash
# The device calls of 2026-11-29 (thirty-second session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s34_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s34_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: bcSM's backflip costs 0.026 of NR on average over three seeds (0.0202, 0.037, 0.019).
# From its last evaluation under pushes (170 M) to its best after the stop, the NR rose 0.028,
# 0.124 and 0.045: does an earlier stop, with 40 M samples to recover instead of 20 M, cost less
# and keep the forces? bcSM's recipe with the pushes stopped at 160 M, on seeds 0 and 1 (against
# b200 and b200_s1):
#   bcSN      680 N forward and up to 156 N sideways, every 4 s, stopped at 160 M, seed 0
#   bcSN_s1   the same, seed 1
# Ran as calls of 548, 541 and 526 s wall (the last with PACK=policies and SECONDS 500): both runs
# ended in call C and were graded there on MJX-Warp; their MuJoCo C tests did not finish in it.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=160000000"
backflip="--clip backflip $push --set env.push_force_max_n=680 --set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bcSN|$backflip;grade_bcSN" \
  "bcSN_s1|$backflip --set run.seed=1;grade_bcSN_s1"
wait
