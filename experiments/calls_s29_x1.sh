#!/usr/bin/env bash
# The device calls of 2026-11-28 (twenty-seventh session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each run graded in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s29_x1.sh SECONDS                 # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s29_x1.sh SECONDS   # the last: every run's best policy back
# Issue 17: the seed-0 runs of the twenty-sixth session, lost with its host. Seed 1 met the
# push-training target with both; seed 0 decides whether one recipe does it on two seeds:
#   ccRWI   the cartwheel pushed up to 330 N forward and 780 N sideways (push_sideways_scale 2.36),
#           a push every 4 s (seed 1: cost 0.011, 550 / 888 N on MJX-Warp)
#   kcRZ    the spinkick's kcRY with sideways pushes 1.15 times the forward (up to 1311 N)
#           (seed 1: cost -0.006, 1081 / 1000 N on MJX-Warp)
# 200 M samples, pushes stopped at 180 M, seed 0. Ran as calls of 548, 541 and 508 s wall (the
# last with PACK=policies and SECONDS 500): both runs ended and were graded in call C.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 2 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
cartwheel="--clip cartwheel $push --set env.push_force_max_n=330 --set env.push_sideways_scale=2.36 --set env.push_interval_s=4"
spinkick="--clip spinkick $push --set env.push_force_max_n=1140 --set env.push_sideways_scale=1.15"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "ccRWI|$cartwheel;grade_ccRWI" \
  "kcRZ|$spinkick;grade_kcRZ"
wait
