#!/usr/bin/env bash
# The device calls of 2026-11-26 (second session) on a lent four-H200 host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_suite_x4.sh 1 505   # GPU 0: the training loop benched on flat ground
#       # and on mixed obstacles, then crawl. GPUs 1-3: the composite's walk and push-trained face-up
#       # getup (issue 14), then the suite's clips that fell short of Table 2 at 48 M, with 100 M
#       # samples (issue 13)
#   bash experiments/calls_suite_x4.sh 2 500   # resumed, then jump, backflip and a 100 M walk
#   bash experiments/calls_suite_x4.sh 3 230   # dance_a, crawl, getup_facedown on to 150 M;
#       # every run exported (one GPU each: eleven exports on one GPU ran out of its memory)
#   bash experiments/calls_suite_x4.sh bench   # the encoder benches (experiments/terrain/README.md)
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
suite="--preset gpu --set run.total_samples=100000000"
push="--set env.events=push --set env.push_force_max_n=400 --set env.push_interval_jitter_s=1.0 --set env.reset_noise_rad=0.3"
b="--preset gpu --num-envs 8192 --clip run --set task.name=heading --kinds train_loop"
b="$b --set physics.contacts_per_world=64 --set physics.constraints_per_world=320"
m="--terrain mixed --set terrain.length_m=40"
bench() {  # GPU NAME ARGS...: one bench on one GPU, its JSON and log into $OUT
  local gpu=$1 name=$2; shift 2
  CUDA_VISIBLE_DEVICES=$gpu python3 -m mjxmimic.cli bench "$@" --out "$OUT/bench_$name.json" > "$OUT/bench_$name.log" 2>&1
}
case $1 in
  1)
    start=$(date +%s)
    (
      # shellcheck disable=SC2086
      bench 0 flat $b; bench 0 mixed $b $m; bench 0 mixed2 $b $m
      left=$(( $2 - $(date +%s) + start ))
      [ $left -gt 60 ] && CUDA_VISIBLE_DEVICES=0 PACK=none bash experiments/device_train.sh $left \
        "crawl|--clip crawl $suite" > "$OUT/lane0.txt"
    ) &
    CUDA_VISIBLE_DEVICES=1,2,3 PACK=none bash experiments/device_train.sh "$2" \
      "walk|--clip walk --preset gpu;getup_faceup_push|--clip getup_faceup $suite $push;spinkick|--clip spinkick $suite" \
      "dance_b|--clip dance_b $suite;getup_facedown|--clip getup_facedown $suite" \
      "dance_a|--clip dance_a $suite;run|--clip run $suite"
    wait
    cat "$OUT/lane0.txt" 2>/dev/null ;;
  2)
    PACK=none bash experiments/device_train.sh "$2" "crawl|--clip crawl $suite;jump|--clip jump $suite" \
      "getup_faceup_push|;spinkick|--clip spinkick $suite" "getup_facedown|;backflip|--clip backflip $suite" \
      "run|--clip run $suite;walk100|--clip walk $suite" ;;
  3)
    x="--set run.total_samples=150000000"
    PACK=none bash experiments/device_train.sh "$2" "dance_a|$x" "crawl|$x" "getup_facedown|$x" "backflip|;walk100|"
    i=0
    for n in $(ls runs); do
      CUDA_VISIBLE_DEVICES=$((i % 4)) python3 -m mjxmimic.cli export "runs/$n" > /dev/null 2>&1 || echo "export $n failed" &
      i=$((i + 1))
    done
    wait
    tar czf - --exclude=checkpoints --exclude=best runs | split -b 15M - "$OUT/policies.tgz." ;;
  bench)
    # shellcheck disable=SC2086
    { bench 0 hm1x1 $b $m --set terrain.heightmap_shape=1,1 & bench 1 hm8x8 $b $m --set terrain.heightmap_shape=8,8 &
      bench 2 hm16x16 $b $m & bench 3 flat2 $b & wait; }
    # branch encoder-patches' networks.py (PatchConv, since merged), carried as .encpatch/, in a
    # copy of the package, run from there: `python -m` puts the working directory first on the path
    rm -rf /tmp/encpatch && mkdir /tmp/encpatch && cp -r mjxmimic /tmp/encpatch/
    cp .encpatch/networks.py /tmp/encpatch/mjxmimic/learn/networks.py
    # shellcheck disable=SC2086
    { (cd /tmp/encpatch && bench 0 patch0 $b $m) & (cd /tmp/encpatch && bench 1 patch1 $b $m) &
      bench 2 main2 $b $m & wait; }
    # shellcheck disable=SC2086
    { bench 0 env_hm1x1 ${b/train_loop/env_step} $m --set terrain.heightmap_shape=1,1 &
      bench 1 env_hm16x16 ${b/train_loop/env_step} $m & wait; } ;;
esac
