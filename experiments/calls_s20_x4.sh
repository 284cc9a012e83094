#!/usr/bin/env bash
# The device calls of 2026-11-27 (eighteenth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s20_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s20_x4.sh SECONDS   # the last: every run's best policy back
# The question (issue 17): does the run's push training meet 1.5 x Table 6 (1080 / 450 N) at an NR
# cost of at most 0.02 when it has more samples after the pushes come in, measured against the
# same budget without pushes and over two seeds? rcL3 (a push every 3 to 4 s from 100 M samples,
# up to 1080 N, 200 M samples) survived 1038 N forward on MuJoCo C at a cost of 0.024 against r200
# with 50 M samples of full pushes; here the same settings with 300 M samples (150 M of full
# pushes), and the preset's run for 300 M samples without pushes, seeds 0 and 1 of each:
#   r300, r300_s1      no pushes
#   rcL3L, rcL3L_s1    rcL3's pushes
# Evaluations every 20 M samples (15 a run). Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
base="--clip run --preset gpu --set run.total_samples=300000000 --set run.eval_every=20000000"
push="$base --set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_start_samples=100000000 --set env.push_ramp_samples=50000000 \
--set env.push_force_max_n=1080 --set env.push_interval_s=3"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "r300|$base;grade_r300" \
  "r300_s1|$base --set run.seed=1;grade_r300_s1" \
  "rcL3L|$push;grade_rcL3L" \
  "rcL3L_s1|$push --set run.seed=1;grade_rcL3L_s1"
