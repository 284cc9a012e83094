#!/usr/bin/env bash
# The device calls of 2026-11-27 (fourteenth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh), each run graded
# in its lane once done (grade_NAME: push test on MJX, NR and push test on MuJoCo C):
#   bash experiments/calls_s16_x4.sh SECONDS          # every call; the runs stay on the machine
#   PACK=policies bash experiments/calls_s16_x4.sh SECONDS   # the last: every run's best policy back
# The questions (issue 17):
# 1. The pose termination measured from the character's root (env.pose_termination_frame=root)
#    without pushes, 100 M samples (the preset's budget): does it keep the preset's NR (world
#    frame: run 0.895, backflip 0.812, spinkick 0.852, cartwheel 0.899), and does it raise
#    Table 6's forces without push training (run 720 / 300 N, backflip 440 / 100, spinkick
#    690 / 600, cartwheel 200 / 470, walk 240 / 300)?
# 2. The run, the backflip and the cartwheel with pushes and the root frame for 200 M samples
#    instead of 100 M (rcR, bcR, ccR of calls_s15_x4.sh: NR costs 0.091, 0.038 and 0.122, target
#    0.02): pushes along the facing or to the sides up to 1.5 x Table 6's larger force of the
#    clip, every 2 +- 1 s, ramped in over 50 M samples.
# Ran as: calls A (510 s, with the install), B (555) and C (PACK=policies, 456) on four H200s;
# records in experiments/robustness/root_frame/. (Call A's exit status 1 came from a summary loop
# of this script, before its fix: no run had a push test yet; device_train.sh now prints the grades.)
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) / 4 - 1 ))
root="--preset gpu --set env.pose_termination_frame=root"
push="$root --set env.events=push --set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 \
--set env.push_ramp_samples=50000000 --set run.total_samples=200000000"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "rcR2|--clip run $push --set env.push_force_max_n=1080;grade_rcR2;r0R|--clip run $root;grade_r0R" \
  "ccR2|--clip cartwheel $push --set env.push_force_max_n=705;grade_ccR2;c0R|--clip cartwheel $root;grade_c0R" \
  "bcR2|--clip backflip $push --set env.push_force_max_n=660;grade_bcR2;b0R|--clip backflip $root;grade_b0R" \
  "k0R|--clip spinkick $root;grade_k0R;w0R|--clip walk $root;grade_w0R"
