#!/usr/bin/env bash
# The device call of 2026-11-28 (nineteenth session, second block) on one lent GPU, after the
# warp-lang transfer and install (experiments/device_train.sh):
#   PACK=policies bash experiments/calls_s21_x1.sh SECONDS
# The question (issue 17, Table 6 without push training): the run trained with a fixed
# exploration std of 0.15 rad (rF15, calls_s21_x2.sh) survived 556 / 375 N on MuJoCo C where the
# preset's learned std left 262 / 338 N, at the same NR. Does the backflip gain as much? bF15: the
# backflip with a fixed std of 0.15, 100 M samples, seed 0; against b100 (learned std, 269 / 250 N
# on MuJoCo C) and Table 6's 440 / 100 N. Graded on MJX in the call if time is left, on MuJoCo C
# afterwards. Ran as one call of 391 s (428 s wall, one H100): bF15 stopped at 90 M samples;
# its best policy (80 M) was graded on MuJoCo C on a 2-core CPU machine.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
export GRADE_WORKERS=$(( $(nproc) - 1 ))
export GRADE_MIN=75
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "bF15|--clip backflip --preset gpu --set run.total_samples=100000000 --set ppo.std_mode=fixed --set ppo.init_action_std=0.15;grade_bF15"
