#!/usr/bin/env bash
# The device calls of 2026-11-29 (thirty-fourth session) on one lent H200 (the only kind lent),
# after the warp-lang transfer and install, two lanes sharing the GPU (experiments/device_train.sh),
# each fine-tuning graded in its lane once done (grade_NAME: push test on MJX, NR and push test on
# MuJoCo C):
#   bash experiments/calls_s36_x1.sh SECONDS           # every call but the last; runs stay there
#   FINAL=1 bash experiments/calls_s36_x1.sh SECONDS   # the last: the 200 M runs' newest and best
#                                                      # checkpoints back, to resume next session
# Issue 17: every push-trained backflip of 200 M (sixteen, three recipes' families) scores 0.818 to
# 0.848, the preset's 0.847 to 0.867. Does fine-tuning the preset's trained backflip with pushes
# (run.init_from) keep its NR and reach 1.5 x Table 6? From b200_s2 (seed 2, NR 0.867), 40 M
# samples with bcSM's pushes (up to 680 N forward, 156 N sideways, every 4 s) ramped over 10 M and
# stopped at 30 M, against the same 40 M without pushes, at two learning rates (a fresh optimiser):
#   ftP      pushes, cosine 1e-4 -> 3e-5        ftN      no pushes, cosine 1e-4 -> 3e-5
#   ftPlo    pushes, constant 3e-5              ftNlo    no pushes, constant 3e-5
# then the preset's backflip of seeds 0 and 1 again (their policies were not kept), the sources of
# the same fine-tuning on two more seeds and a measure of how far one seed's run moves between two
# runs (against b200 0.847 and b200_s1 0.859); they end next session (FINAL=1 packs them).
#   b200r    preset backflip, 200 M, seed 0    b200r_s1  the same, seed 1
# Ran as one call of 566 s wall (SECONDS 530) after fourteen transfer calls: ftP and ftN finished
# and were graded on MJX-Warp (their MuJoCo C tests were cut off by the call's end), ftPlo had not
# passed its compilation and ftNlo had trained three iterations. The host then went back, idle for
# 30 s while the results were read, with every run on it: the block ended there, and
# calls_s36_x2.sh took what it had shown further. Records: experiments/robustness/fine_tune/.
# Carried (ignored folders): .clips/ (DeepMimic's motions), .data/b200_s2.npz.
set -u
source=".data/b200_s2.npz"
tune="--clip backflip --preset gpu --init-from $source --set run.seed=2 --set run.total_samples=40000000 \
--set run.eval_every=5000000"
fast="--set ppo.learning_rate=1e-4 --set ppo.learning_rate_schedule=cosine --set ppo.learning_rate_final=3e-5"
slow="--set ppo.learning_rate=3e-5 --set ppo.learning_rate_schedule=constant"
push="--set env.pose_termination_frame=root --set env.events=push --set env.push_directions=table6 \
--set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=10000000 --set env.push_stop_samples=30000000 \
--set env.push_force_max_n=680 --set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
preset="--clip backflip --preset gpu --set run.total_samples=200000000"
if [ "${FINAL:-0}" = 1 ]; then
  bash experiments/device_train.sh "$1" "b200r|$preset" "b200r_s1|$preset --set run.seed=1"
else
  PACK=none bash experiments/device_train.sh "$1" \
    "ftP|$tune $fast $push;grade_ftP;ftPlo|$tune $slow $push;grade_ftPlo;b200r|$preset" \
    "ftN|$tune $fast;grade_ftN;ftNlo|$tune $slow;grade_ftNlo;b200r_s1|$preset --set run.seed=1"
fi
wait
