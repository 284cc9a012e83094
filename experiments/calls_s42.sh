#!/usr/bin/env bash
# The device block of 2026-11-30 (fortieth session) on a lent one-H200 host, after the transfer
# and install of experiments/README.md ("device time"): issue 13, plan item 2a. The kick on
# today's `gpu` preset blew up at 31.5 M samples (kickRR: mean KL 0.09 -> 0.86 -> 4,724, its
# smallest std 0.008): the same run with a floor of 0.02 on the learned std (ppo.min_action_std),
# the same with an update that undoes a step beyond a KL of 0.5 (ppo.max_kl), the KL stop on
# seed 1, then the crawl (200 M; crawlRR2 spiked at 43 M) with the KL stop. One lane, the runs
# staying on the machine between calls:
#   bash experiments/calls_s42.sh SECONDS                  # every call but the last
#   PACK=policies bash experiments/calls_s42.sh SECONDS    # the last: every run's best policy back
# A run starts only while 30 s of the call are left.
# Carried (ignored folders): .clips/ (DeepMimic's motions).
# Ran as calls of 548 s (SECONDS 530), 556 s (535) and 496 s (PACK=policies, 470) after
# twenty-two transfer calls. The first call's lane had the floor, not the KL stop, on seed 1 and
# the crawl (kickF2_s1, crawlF2; neither started); the floor having failed in it, they were
# changed to the lines below before the second. The crawl stopped at 165 M samples, unfinished.
set -u
floor="--set ppo.min_action_std=0.02"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "@0/30 kickF2|--clip kick --preset gpu $floor;kickK|--clip kick --preset gpu --set ppo.max_kl=0.5;kickK_s1|--clip kick --preset gpu --set ppo.max_kl=0.5 --set run.seed=1;crawlK|--clip crawl --preset gpu --set ppo.max_kl=0.5 --set run.total_samples=200000000"
