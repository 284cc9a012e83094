#!/usr/bin/env bash
# The device calls of 2026-11-29 (twenty-ninth session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s31_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s31_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: the backflip's push training passes its forces on both seeds but costs 0.023 to 0.041 on
# seed 1 with every setting tried (bcSI_s1, up to 730 N forward and 168 N sideways, a push every
# 4 s, stopped at 180 M: 0.023, 762 / 312 N on MJX-Warp). bcSK: the same with a lower forward
# maximum, 620 N, and sideways up to 161 N (push_sideways_scale 0.26, above 1.5 x Table 6's 150 N),
# on both seeds:
#   bcSK     seed 0
#   bcSK_s1  seed 1
# 200 M samples, pushes stopped at 180 M. Ran as calls of 549, 541 and 495 s wall (the last with
# PACK=policies and SECONDS 480): both runs ended in call C with time for their MJX push test only.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
backflip="--clip backflip $push --set env.push_force_max_n=620 --set env.push_sideways_scale=0.26 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bcSK|$backflip;grade_bcSK" \
  "bcSK_s1|$backflip --set run.seed=1;grade_bcSK_s1"
wait
