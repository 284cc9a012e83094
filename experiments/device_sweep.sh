#!/usr/bin/env bash
# Sweeps on the lent GPU through Ray Tune: a Ray cluster started here with the machine's GPU,
# several sweeps submitted to it at once (or one after another with SERIAL=1), their trials
# sharing the GPU (GPUS_PER_TRIAL each, so 0.25 runs four at once), each call bounded by SECONDS.
#   bash experiments/device_sweep.sh SECONDS GPUS_PER_TRIAL "SPEC [sweep args]" ...
# The run folders stay on the machine between calls (a later call resumes them); what comes back
# in $OUT is each sweep's log and runs.tgz.* with every run's config, metrics, logs, report and
# latest checkpoint exported (RUN/policy.npz, for the CPU player and videos: a machine can be
# given back before the next call). FINAL=1: also each run's evaluation of its latest and best
# checkpoints (RUN/eval_*.json, by `mjxmimic eval`).
set -uf  # -f: the sweep arguments hold shell patterns (--only), passed on unexpanded
seconds=$1 share=$2; shift 2
export PYTHONUNBUFFERED=1
ray_cli() { python3 -c "import sys; from ray.scripts.scripts import main; sys.exit(main())" "$@"; }
ray_cli start --head --num-gpus "$(nvidia-smi -L 2>/dev/null | wc -l)" --disable-usage-stats \
  --include-dashboard false > "$OUT/ray_start.log" 2>&1 || { tail -n 20 "$OUT/ray_start.log"; exit 1; }

sweep() {  # SPEC [sweep args]: one `mjxmimic sweep` call on the cluster, its log in $OUT
  local name; name=$(basename "${1%.json}")
  # shellcheck disable=SC2068
  python3 -m mjxmimic.cli sweep $@ --executor ray --address auto --gpus-per-trial "$share" \
    --max-seconds "$seconds" > "$OUT/$name.log" 2>&1
  echo "== sweep $name: exit $?"; grep -v -i warp "$OUT/$name.log" | tail -n 4
}

pids=()
for spec in "$@"; do
  if [ "${SERIAL:-0}" = 1 ]; then sweep $spec; else sweep $spec & pids+=($!); fi
done
[ ${#pids[@]} -gt 0 ] && wait "${pids[@]}"
ray_cli stop > /dev/null 2>&1

set +f
runs=$(for f in runs/sweeps/*/*/config.json; do dirname "$f"; done)
for run in $runs; do  # samples, seconds and the newest evaluation of every run
  python3 - "$run" <<'PY'
import json, sys
rows = [json.loads(line) for line in open(sys.argv[1] + "/metrics.jsonl")]
ev = [r for r in rows if "eval/nr" in r]
last = ev[-1] if ev else {}
print(f"{sys.argv[1]}: {rows[-1]['step']:,} samples, {rows[-1]['wall']:.0f} s; last evaluation "
      + ", ".join(f"{k[5:]} {v:.3f}" for k, v in last.items() if k.startswith("eval/") and isinstance(v, float)))
PY
done
for run in $runs; do
  if [ "${FINAL:-0}" = 1 ]; then
    for which in latest best; do
      python3 -m mjxmimic.cli eval "$run" --checkpoint "$which" --json > "$run/eval_$which.json" 2> "$run/eval_$which.err" \
        || tail -n 3 "$run/eval_$which.err"
    done
  fi
  [ -d "$run/checkpoints" ] && { python3 -m mjxmimic.cli export "$run" --checkpoint latest > /dev/null 2>&1 || echo "export $run failed"; }
done
tar czf - --exclude=checkpoints --exclude=best --exclude=ray runs/sweeps | split -b 15M - "$OUT/runs.tgz."
