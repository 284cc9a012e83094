#!/usr/bin/env bash
# The device calls of 2026-11-27 (seventeenth session) on a lent two-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s19_x2.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s19_x2.sh SECONDS   # the last: every run's best policy back
# The question (issue 17): the run's push training between rcL4 (a push every 4 to 5 s from 100 M
# samples, up to 1080 N: NR cost 0.012, 706 N forward on MuJoCo C, short of 1080 N) and rcR2 (a
# push every 2 to 3 s from the start: 1300 N, cost 0.054). Pushes from 100 M on, ramped over 50 M,
# along the facing or to the sides, root frame, 200 M samples, seed 0:
#   rcL4F  every 4 to 5 s, up to 1620 N forward, sideways times 0.42 (up to 680 N; Table 6's ratio)
#   rcL3F  every 3 to 4 s, the same forces
#   rcL4X  every 4 to 5 s, up to 1620 N both ways
#   rcL3   every 3 to 4 s, up to 1080 N both ways
# Ran as: calls A (530 s, with the install; 548 s wall), B (560; 587 s wall) and C (PACK=policies,
# 469; 360 s wall) on two H200s; C ran out before rcL3 and rcL3F were graded, which were then
# graded on MuJoCo C on a 2-core CPU machine. Records in experiments/robustness/late/.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
late="--clip run --preset gpu --set run.total_samples=200000000 --set env.pose_termination_frame=root \
--set env.events=push --set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 \
--set env.push_start_samples=100000000 --set env.push_ramp_samples=50000000"
strong="$late --set env.push_force_max_n=1620"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rcL4F|$strong --set env.push_interval_s=4 --set env.push_sideways_scale=0.42;grade_rcL4F;rcL3F|$strong --set env.push_interval_s=3 --set env.push_sideways_scale=0.42;grade_rcL3F" \
  "rcL4X|$strong --set env.push_interval_s=4;grade_rcL4X;rcL3|$late --set env.push_force_max_n=1080 --set env.push_interval_s=3;grade_rcL3"
