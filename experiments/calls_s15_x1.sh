#!/usr/bin/env bash
# The one-GPU device call of 2026-11-27 (thirteenth session), after the warp-lang transfer and
# install: the start and the evaluations after two changes of this session (the learner's init as
# one compiled program; evaluations that stop once every episode has ended, a while loop under
# Warp too), against the twelfth session's run of the same seed (experiments/multi_gpu/s14/b1_s3:
# first iteration at 21 s, evaluations 19 s, NR 0.75 after 50 M samples and 163 s).
#   bash experiments/calls_s15_x1.sh
# 1. A one-iteration run compiles everything and Warp's kernels (Warp's kernel cache warm; its
#    train step has another run.total_samples, so the profiled start compiled the backflip's).
# 2. A profile of a warm start (run.max_seconds=1: it stops before the first iteration).
# 3. The backflip to NR 0.75, seed 3, as b1_s3 was run.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips PYTHONUNBUFFERED=1
bf="--clip backflip --preset gpu --set run.total_samples=100000000 --set run.target_nr=0.75"
python3 -m mjxmimic.cli train --out runs/warm $bf --set run.total_samples=131072 > "$OUT/warm.log" 2>&1
python3 -m cProfile -o "$OUT/start.prof" -m mjxmimic.cli train --out runs/prof $bf --set run.max_seconds=1 \
  > "$OUT/prof.log" 2>&1
python3 -m mjxmimic.cli train --out runs/b1_s3 $bf --set run.seed=3 > "$OUT/b1_s3.log" 2>&1
cp runs/b1_s3/metrics.jsonl "$OUT/b1_s3.metrics.jsonl"
for f in warm prof b1_s3; do echo "== $f"; tr '\r' '\n' < "$OUT/$f.log" | grep -v -i warp | tail -n 12; done
python3 - <<'PY'
import json
for line in open("runs/b1_s3/metrics.jsonl"):
    d = json.loads(line)
    if "eval/nr" in d:
        print(f"  samples {d['step']:>11,}  wall {d['wall']:6.1f} s  NR {d['eval/nr']:.3f}  falls "
              f"{d['eval/fall_rate']:.2f}  eval {d['eval/eval_seconds']:.2f} s  steps {d.get('eval/steps_run')}")
PY
