#!/usr/bin/env bash
# The device block of 2026-11-29 (thirty-ninth session) on a lent two-H200 host, after the
# transfer and install of experiments/README.md ("device time"): issue 13 on today's `gpu` preset
# (the paper form as written with the reference_root observation term), two lanes of one GPU each,
# the runs staying on the machine between calls:
#   bash experiments/calls_s41_x2.sh SECONDS                  # every call but the last
#   PACK=policies bash experiments/calls_s41_x2.sh SECONDS    # the last: every run's best policy back
#   GPU 0: the backflip with 200 M samples (0.005 short of Table 2 at 100 M, still rising), then
#          the kick and the punch with the preset as it stands (they reached Table 2 without the
#          term), 100 M each;
#   GPU 1: dance_a and the crawl with 200 M samples (0.004 and 0.027 short at 100 M).
# A lane starts a run only while 30 s of the call are left.
# The first call also evaluates the reference_root backflip's policy on MJX-Warp under other
# solver iterations (experiments/paper_form/mjx_iterations.py) beside GPU 1's run.
# Carried (ignored folders): .clips/ (DeepMimic's motions) in every call; .data/bpRR.npz in the first.
# Ran as calls of 551 s (SECONDS 530), 557 s (545) and 440 s (PACK=policies, 465) after
# twenty-two transfer calls; every run ended in them (the kick and the punch started in the second
# call, the crawl at its start). The solver-iteration evaluations ran in the first call and, the
# policy file having stayed on the machine, again in the third (mjx_iterations.json of both).
set -u
long="--set run.total_samples=200000000"
if [ -f .data/bpRR.npz ] && [ -z "${SKIP_ITERATIONS:-}" ]; then
  mkdir -p "$OUT"
  CUDA_VISIBLE_DEVICES=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.15 PYTHONUNBUFFERED=1 MJXMIMIC_CLIPS=$PWD/.clips \
    timeout $(( $1 - 20 )) python3 experiments/paper_form/mjx_iterations.py .data/bpRR.npz 4x4 1x1 16x16 4x16 16x4 \
    > "$OUT/mjx_iterations.json" 2> "$OUT/mjx_iterations.log" &
fi
PACK=${PACK:-none} bash experiments/device_train.sh "$1" \
  "@0/30 bpRR2|--clip backflip --preset gpu $long;kickRR|--clip kick --preset gpu;punchRR|--clip punch --preset gpu" \
  "@1/30 danceaRR2|--clip dance_a --preset gpu $long;crawlRR2|--clip crawl --preset gpu $long"
wait
