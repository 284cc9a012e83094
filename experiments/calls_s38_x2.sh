#!/usr/bin/env bash
# The device block of 2026-11-29 (thirty-sixth session) on a lent two-H200 host, after the
# warp-lang transfer and install (experiments/device_train.sh), in two phases:
#   bash experiments/calls_s38_x2.sh 2gpu SECONDS                  # call A: both GPUs, one run at a time
#   bash experiments/calls_s38_x2.sh lanes SECONDS                 # then: one lane a GPU; runs stay there
#   PACK=policies bash experiments/calls_s38_x2.sh lanes SECONDS   # the last: every run's best policy back
# Issue 20 (phase 2gpu): the backflip's time to NR 0.75 on two GPUs, setting "a" (twice the envs
# and minibatches), for seeds 6 to 8, whose 1-GPU runs are in multi_gpu/s14 (b1_s6 .. b1_s8), as
# b2a_s2 .. b2a_s5 there: the 2-GPU bench first (the train loop at 16384 envs, which also fills
# Warp's kernel cache), a warm-up that fills JAX's compilation cache, then the runs, each started
# only while 200 s of the call are left.
# Then two lanes, one GPU each:
#   GPU 0, issue 17: the preset's seed-2 backflip again (b200_s2, 200 M; its policy was lost with
#     an earlier checkout), then fine-tuned from it with bcSM's pushes (ftT: 1e-4 falling to 3e-5,
#     pushes ramped over 20 M and stopped at 80 M, no checkpoint before 80 M kept as the best,
#     100 M in all), graded on MJX-Warp and MuJoCo C.
#   GPU 1, issue 13: the roll on the paper form as written with 200 M samples (rollP2; rollP's
#     0.703 at 100 M was still rising), then the punch on it with 100 M (punchP).
# A lane starts a run only while 30 s of the call are left, so that ftT never starts (and takes
# its networks) from a b200_s2 stopped at a call's end.
# Ran as calls of 339 s (2gpu, SECONDS 510: the bench, the warm-up and b2a_s6; b2a_s7 and b2a_s8
# found 181 s left and did not start), 541 s (lanes, 530) and 554 s (PACK=policies lanes, 535)
# after sixteen transfer calls: every lane run ended in the last call; grade_ftT's MJX push test
# finished there, its MuJoCo C tests and grade_b200_s2 did not (run on the CPU machine instead).
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
bf="--clip backflip --preset gpu --set run.total_samples=100000000 --set run.target_nr=0.75"
two_a="$bf --set ppo.num_envs=16384 --set ppo.num_minibatches=16"
paper="--preset gpu --set reward.kind=paper"
ft="--clip backflip --preset gpu --init-from runs/b200_s2 --set run.seed=2 --set run.total_samples=100000000 \
--set run.eval_every=5000000 --set ppo.learning_rate=1e-4 --set ppo.learning_rate_schedule=cosine \
--set ppo.learning_rate_final=3e-5 --set env.pose_termination_frame=root --set env.events=push \
--set env.push_directions=table6 --set env.push_interval_jitter_s=1.0 --set env.push_ramp_samples=20000000 \
--set env.push_stop_samples=80000000 --set run.best_from_samples=80000000 --set env.push_force_max_n=680 \
--set env.push_sideways_scale=0.23 --set env.push_interval_s=4"
if [ "$1" = 2gpu ]; then
  PACK=none bash experiments/device_train.sh "$2" \
    "@0,1/200 bench_2gpu|--preset gpu --clip walk --kinds train_loop --num-envs 16384;warm_2a|$two_a;\
b2a_s6|$two_a --set run.seed=6;b2a_s7|$two_a --set run.seed=7;b2a_s8|$two_a --set run.seed=8"
else
  PACK=${PACK:-none} bash experiments/device_train.sh "$2" \
    "@0/30 b200_s2|--clip backflip --preset gpu --set run.total_samples=200000000 --set run.seed=2;ftT|$ft;grade_ftT;grade_b200_s2" \
    "@1/30 rollP2|--clip roll $paper --set run.total_samples=200000000;punchP|--clip punch $paper"
fi
wait
