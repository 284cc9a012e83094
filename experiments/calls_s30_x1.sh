#!/usr/bin/env bash
# The device calls of 2026-11-28/29 (twenty-eighth session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s30_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s30_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: the cartwheel's ccRWI (up to 330 N forward, 780 N sideways, a push every 4 s) cost
# 0.023 and 0.011 on seeds 0 and 1, with its sideways force 180 to 240 N above 1.5 x Table 6's
# 705 N on every simulator. ccRWJ: the same with weaker sideways pushes, up to 739 N
# (push_sideways_scale 2.24, about 5 % above 705 N), on both seeds:
#   ccRWJ     seed 0
#   ccRWJ_s1  seed 1
# 200 M samples, pushes stopped at 180 M. Ran as calls of 549, 541 and 525 s wall (the last with
# PACK=policies and SECONDS 510): both runs ended in call C with time for their MJX push test only.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
cartwheel="--clip cartwheel $push --set env.push_force_max_n=330 --set env.push_sideways_scale=2.24 --set env.push_interval_s=4"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "ccRWJ|$cartwheel;grade_ccRWJ" \
  "ccRWJ_s1|$cartwheel --set run.seed=1;grade_ccRWJ_s1"
wait
