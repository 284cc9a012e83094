#!/usr/bin/env bash
# The device block of 2026-11-29 (thirty-seventh session) on a lent two-H200 host, after the
# warp-lang transfer and install (experiments/device_train.sh): issue 13's clips on the paper form
# as written, two lanes of one GPU each, the runs staying on the machine between calls:
#   bash experiments/calls_s39_x2.sh SECONDS                  # every call but the last
#   PACK=policies bash experiments/calls_s39_x2.sh SECONDS    # the last: every run's best policy back
#   GPU 0: the clips that end (kick, spinkick, getup_facedown, jump), then dance_a, 100 M each;
#   GPU 1: the spin with 200 M (spinP's 0.611 against 0.664 was still rising at 100 M), then
#     dance_b and crawl, 100 M each.
# A lane starts a run only while 30 s of the call are left.
# Ran as calls of 549 s (SECONDS 530), 557 s (545) and 558 s (PACK=policies, 522) after seventeen
# transfer calls: every run ended in them but danceaP, stopped at 80 M samples by the last call's end.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
paper="--preset gpu --set reward.kind=paper"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "@0/30 kickP|--clip kick $paper;spinkickP|--clip spinkick $paper;getupfdP|--clip getup_facedown $paper;\
jumpP|--clip jump $paper;danceaP|--clip dance_a $paper" \
  "@1/30 spinP2|--clip spin $paper --set run.total_samples=200000000;dancebP|--clip dance_b $paper;\
crawlP|--clip crawl $paper"
wait
