#!/usr/bin/env bash
# The device block of 2026-11-29 (thirty-eighth session) on a lent two-H200 host, after the
# transfer and install of experiments/README.md ("device time"): issue 13's looping clips on the
# paper form as written with the reference_root observation term (the policy sees where its
# reference root is and which way it faces), two lanes of one GPU each, 100 M samples a run, the
# runs staying on the machine between calls:
#   bash experiments/calls_s40_x2.sh SECONDS                  # every call but the last
#   PACK=policies bash experiments/calls_s40_x2.sh SECONDS    # the last: every run's best policy back
#   GPU 0: jump, spin (the two that turned 28-32 degrees off their reference), dance_a, spinkick;
#   GPU 1: crawl, dance_b, backflip, cartwheel.
# A lane starts a run only while 30 s of the call are left.
# Ran as calls of 550 s (SECONDS 530), 557 s (545) and 349 s (PACK=policies, 495) after nineteen
# transfer calls; every run ended in them. In the first two calls GPU 0's queue ended with the
# cartwheel and GPU 1's with the jump again with clip.velocity=central; neither had started when
# the last call moved the cartwheel to GPU 1 and dropped the second jump.
# Carried (ignored folders): .clips/ (DeepMimic's motions), in every call.
set -u
rr="--preset gpu --set reward.kind=paper --set env.observations=phase,root_height,bodies,reference_root"
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "@0/30 jumpRR|--clip jump $rr;spinRR|--clip spin $rr;danceaRR|--clip dance_a $rr;\
spinkickRR|--clip spinkick $rr" \
  "@1/30 crawlRR|--clip crawl $rr;dancebRR|--clip dance_b $rr;bpRR|--clip backflip $rr;\
cartRR|--clip cartwheel $rr"
wait
