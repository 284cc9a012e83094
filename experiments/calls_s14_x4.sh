#!/usr/bin/env bash
# The device calls of 2026-11-27 (twelfth session) on a lent four-GPU host, after the warp-lang
# transfer and install (experiments/device_train.sh; every call the same, runs that are done are
# skipped, the rest stay on the machine):
#   bash experiments/calls_s14_x4.sh SECONDS
# The question (issue 20): the backflip's time to NR 0.75 on two GPUs against one, over more
# seeds, with JAX's compilation cache warm (each lane first compiles once: warm_*) so that a run's
# start is loading, not compiling. Two ways to use the second GPU: "a" doubles the envs and the
# minibatches (the earlier runs' setting, twice the samples per iteration); "d" doubles the envs
# and halves the unroll, so that an iteration has the samples, minibatches and updates of one GPU
# (first call only: its seed 2 did not reach the target in 100 M); "e" is "a" with the learning
# rate (start and end of its cosine) times sqrt(2) for the doubled batch (second and third calls).
# Lanes 1 and 2: one GPU each (seeds 2 to 9); lane 3: GPUs 2 and 3 together. A lane starts a run
# only while enough of the call is left for it to finish (360 s on one GPU, 220 s on two).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
bf="--clip backflip --preset gpu --set run.total_samples=100000000 --set run.target_nr=0.75"
two_a="$bf --set ppo.num_envs=16384 --set ppo.num_minibatches=16"
two_d="$bf --set ppo.num_envs=16384 --set ppo.unroll_length=8"
one() { local s out=""; for s in "$@"; do out+=";b1_s$s|$bf --set run.seed=$s"; done; echo "${out#;}"; }
two_e="$two_a --set ppo.learning_rate=0.000424 --set ppo.learning_rate_final=0.0000424"
two=";b2a_s2|$two_a --set run.seed=2;b2d_s2|$two_d --set run.seed=2;warm_2e|$two_e"
for s in 3 4 5 6 7; do two+=";b2a_s$s|$two_a --set run.seed=$s;b2e_s$s|$two_e --set run.seed=$s"; done
PACK=none bash experiments/device_train.sh "$1" \
  "@0/360 warm_1a|$bf;$(one 2 3 4 5)" \
  "@1/360 warm_1b|$bf;$(one 6 7 8 9)" \
  "@2,3/220 warm_2a|$two_a;warm_2d|$two_d$two"
