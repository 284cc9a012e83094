#!/usr/bin/env bash
# The device calls of 2026-11-28 (twenty-sixth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s28_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s28_x4.sh SECONDS   # the last: every run's best policy back
# Issue 17. Each setting tried for the cartwheel and the backflip met the push-training target on
# one seed of two (costs 0.002 to 0.067); the spinkick's kcRY_s1 survives 894 N sideways on
# MJX-Warp against 900 N. Each on both seeds, 200 M samples, pushes stopped at 180 M:
#   ccRW[_s1]    the cartwheel's pushes weaker forward: up to 330 N forward (1.1 x its 300 N
#                target) and 780 N sideways (push_sideways_scale 2.36), instead of 780 N both ways
#   ccRWI[_s1]   ccRW with a push every 4 s instead of every 2 s (env.push_interval_s)
#   bcSI[_s1]    the backflip's bcSY (730 N forward, 0.23 of it sideways) with a push every 4 s
#   kcRZ[_s1]    the spinkick's kcRY with sideways pushes 1.15 times the forward (up to 1311 N)
# Seed 1 first. Call A also tests kcRY's exported policy (.data/kcRY.npz) on MJX-Warp beside
# lane 3's start: it has a test on MJX-JAX and MuJoCo C only. Carried (ignored folders): .clips/
# (DeepMimic's motions) and, in call A, .data/.
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
export GRADE_MIN=75  # the MJX push test and the export fit; the MuJoCo C tests run on if time is left
if [ -f .data/kcRY.npz ] && [ ! -f runs/kcRY_push_warp.json ]; then
  mkdir -p runs
  CUDA_VISIBLE_DEVICES=3 XLA_PYTHON_CLIENT_MEM_FRACTION=0.15 timeout 400 \
    python3 -m mjxmimic.cli eval .data/kcRY.npz --push --json > runs/kcRY_push_warp.json 2> "$OUT/kcRY_push_warp.log" \
    && cp runs/kcRY_push_warp.json "$OUT/" &
fi
long="--preset gpu --set run.total_samples=200000000"
push="$long --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=50000000 --set env.push_stop_samples=180000000"
cartwheel="--clip cartwheel $push --set env.push_force_max_n=330 --set env.push_sideways_scale=2.36"
backflip="--clip backflip $push --set env.push_sideways_scale=0.23 --set env.push_force_max_n=730 --set env.push_interval_s=4"
spinkick="--clip spinkick $push --set env.push_force_max_n=1140 --set env.push_sideways_scale=1.15"
every4="--set env.push_interval_s=4"
s1="--set run.seed=1"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "ccRW_s1|$cartwheel $s1;grade_ccRW_s1;ccRW|$cartwheel;grade_ccRW" \
  "ccRWI_s1|$cartwheel $every4 $s1;grade_ccRWI_s1;ccRWI|$cartwheel $every4;grade_ccRWI" \
  "bcSI_s1|$backflip $s1;grade_bcSI_s1;bcSI|$backflip;grade_bcSI" \
  "kcRZ_s1|$spinkick $s1;grade_kcRZ_s1;kcRZ|$spinkick;grade_kcRZ"
wait
