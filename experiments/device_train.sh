#!/usr/bin/env bash
# Train runs on the lent GPU within one 10-minute device call, streaming their metrics into $OUT
# as they go and packing the run folders (latest checkpoint) at the end, so that a run can be
# resumed in the next call (newest checkpoint only; runs_NAME.tgz.* split below the 16 MB file
# limit; here: cat runs_NAME.tgz.* | tar xzf -).
#   bash experiments/device_train.sh SECONDS "LANE" ["LANE" ...]
# A LANE is "NAME|ARGS" or several of them joined by ';' (run one after the other); lanes run side
# by side. ARGS are `mjxmimic train` arguments; an existing runs/NAME is resumed instead (with
# its --set run.* and ppo.learning_rate* keys of ARGS, the rest dropped). Each lane ends within
# SECONDS: a run gets the time its lane has left.
# A NAME that starts with "bench_" runs `mjxmimic bench ARGS` instead (its JSON and log come back
# together in bench.tgz), so that a lane can measure on its GPU before it trains.
# Several lanes with a GPU for each (of those CUDA_VISIBLE_DEVICES names, else of the machine): one
# GPU per lane; otherwise they share the GPUs (one lane alone trains data-parallel).
# A lane that starts with "@GPUS[/MIN] " (e.g. "@2,3/200 ") trains on those GPUs (data-parallel
# over them) and starts a run only while at least MIN seconds of the call are left (so that a
# time-to-skill run is not cut in two).
# A NAME that starts with "grade_" grades the run of the rest of its name once it is done: its
# best checkpoint's push test on MJX (`mjxmimic eval RUN --push`, on the lane's GPU), then its
# exported policy's NR and push test on MuJoCo C (`mjxmimic play`, on GRADE_WORKERS CPU cores,
# by default half the machine's less one, beside the lane's next run); a run not done, or graded
# already, is skipped, and so is a grade with less than GRADE_MIN seconds (default 75: the MJX push
# test and the export fit; the MuJoCo C tests run on while time is left) left in the call. The
# call's report lists each run's grades under its evaluations. GRADE_PUSH=0 leaves out both push
# tests (the NR on MuJoCo C only).
# Clips come from .clips/ (carried with the call) unless MJXMIMIC_CLIPS names another folder;
# without either, only resumed runs (which keep their own copies) find theirs, so say so.
# A NAME that starts with "warm_" only builds and compiles (run.max_seconds=1), so that the
# runs after it load their programs from the compilation cache. Runs that are done (eval.json)
# and warm-ups that ran are skipped.
# PACK=policies: instead of the checkpoints, bring back each run's exported best policy
# (runs/NAME/policy.npz) with its config, metrics and logs (for runs that will not be resumed);
# PACK=best: the same plus each run's best checkpoint (runs/NAME/best), to export again later.
# PACK=none: bring back the logs, metrics and the runs' small JSON files (config, evaluation,
# grades) and, once each, the policies that grades exported (in logs.tgz.*, 15 MiB parts: cat
# logs.tgz.* | tar xzf -); the runs stay on the warm machine for the next call. A host given back
# between calls (after 30 s idle) then takes only the runs still training with it.
set -u
seconds=$1; shift
deadline=$(( $(date +%s) + seconds ))
export PYTHONUNBUFFERED=1
if [ -z "${MJXMIMIC_CLIPS:-}" ] && [ -d .clips ]; then export MJXMIMIC_CLIPS=$PWD/.clips; fi
[ -n "${MJXMIMIC_CLIPS:-}" ] || echo "device_train.sh: no .clips/ carried and no MJXMIMIC_CLIPS: new runs of DeepMimic's clips will not find them"
GRADE_WORKERS=${GRADE_WORKERS:-$(( $(nproc) > 3 ? $(nproc) / 2 - 1 : 1 ))}
GRADE_MIN=${GRADE_MIN:-75}
GRADE_PUSH=${GRADE_PUSH:-1}
# the GPUs this script may use: those CUDA_VISIBLE_DEVICES names, else all of the machine's
if [ -n "${CUDA_VISIBLE_DEVICES:-}" ]; then IFS=, read -ra gpus <<< "$CUDA_VISIBLE_DEVICES"
else mapfile -t gpus < <(nvidia-smi --query-gpu=index --format=csv,noheader 2>/dev/null); fi
own_gpu=0
if [ $# -gt 1 ] && [ ${#gpus[@]} -ge $# ]; then own_gpu=1; fi
if [ "$own_gpu" = 1 ]; then export XLA_PYTHON_CLIENT_MEM_FRACTION=0.75
else export XLA_PYTHON_CLIENT_MEM_FRACTION=$(python3 -c "print(round(0.75/$#, 2))"); fi

train() {  # NAME ARGS...
  local name=$1; shift
  local left=$(( deadline - $(date +%s) )) folder=--out
  if [ -f "runs/$name/eval.json" ] || { [[ $name == warm_* ]] && [ -d "runs/$name" ]; }; then return; fi  # done
  if [ "$left" -le "${min_left:-0}" ]; then echo "runs/$name: not started, $left s left in this call"; return; fi
  # resumed (a run stopped before its first checkpoint starts over from its config): of ARGS,
  # only what a resume may change
  if [ -f "runs/$name/config.json" ]; then
    folder=--resume
    local keep=()
    while [ $# -gt 0 ]; do
      if [ "$1" = --set ] && [[ ${2:-} == run.* || ${2:-} == ppo.learning_rate* ]]; then keep+=("$1" "$2"); shift; fi
      shift
    done
    set -- "${keep[@]}"
  fi
  local limit=$left; [[ $name == warm_* ]] && limit=1
  timeout -s INT $((left + 60)) python3 -m mjxmimic.cli train "$folder" "runs/$name" "$@" \
    --set run.max_seconds=$limit > "$OUT/$name.log" 2>&1
}

bench() {  # NAME ARGS...
  local name=$1; shift
  mkdir -p /tmp/bench
  timeout $(( deadline - $(date +%s) )) python3 -m mjxmimic.cli bench "$@" --out "/tmp/bench/$name.json" > "/tmp/bench/$name.log" 2>&1
}

keep_logs() {  # each run's log of this call into its folder (a run done in an earlier call has none)
  for n in "${names[@]}"; do
    [ -f "$OUT/$n.log" ] && mv "$OUT/$n.log" "runs/$n/train_$(date +%s).log"; rm -f "$OUT/$n.metrics.jsonl"
  done
}

grade() {  # grade_NAME
  local run=runs/${1#grade_} left=$(( deadline - $(date +%s) ))
  local last=push_cpu.json; [ "$GRADE_PUSH" = 0 ] && last=play_cpu.json
  [ -f "$run/eval.json" ] && [ ! -f "$run/$last" ] || return 0
  if [ "$left" -lt "$GRADE_MIN" ]; then echo "$run: not graded, $left s left in this call"; return; fi
  [ "$GRADE_PUSH" = 0 ] || timeout -k 10 "$left" python3 -m mjxmimic.cli eval "$run" --push --checkpoint best > "$run/push_mjx.log" 2>&1
  XLA_PYTHON_CLIENT_PREALLOCATE=false timeout -k 10 "$left" python3 -m mjxmimic.cli export "$run" > "$run/export.log" 2>&1 \
    || return
  local test tests=(play push); [ "$GRADE_PUSH" = 0 ] && tests=(play)
  for test in "${tests[@]}"; do
    local flags=(--json); [ $test = push ] && flags+=(--push --workers "$GRADE_WORKERS")
    (timeout -k 10 $(( deadline - $(date +%s) )) python3 -m mjxmimic.cli play "$run/policy.npz" "${flags[@]}" \
      > "$run/${test}_cpu.json.part" 2> "$run/${test}_cpu.log" && mv "$run/${test}_cpu.json.part" "$run/${test}_cpu.json") &
  done
}

names=()
pids=()
i=0
for lane in "$@"; do
  lane_gpus="" min_left=0
  if [[ $lane == @* ]]; then
    opts=${lane%% *}; lane=${lane#* }; opts=${opts#@}
    lane_gpus=${opts%%/*}; [[ $opts == */* ]] && min_left=${opts#*/}
  fi
  IFS=';' read -ra specs <<< "$lane"
  for spec in "${specs[@]}"; do [[ $spec == bench_* || $spec == grade_* ]] || names+=("${spec%%|*}"); done
  (
    if [ -n "$lane_gpus" ]; then export CUDA_VISIBLE_DEVICES=$lane_gpus
    elif [ "$own_gpu" = 1 ]; then export CUDA_VISIBLE_DEVICES=${gpus[$i]}; fi
    for spec in "${specs[@]}"; do
      job=train; [[ $spec == bench_* ]] && job=bench; [[ $spec == grade_* ]] && job=grade
      # shellcheck disable=SC2086
      $job "${spec%%|*}" ${spec#*|}
    done
    wait  # the lane's grading on the CPUs
  ) &
  pids+=($!)
  i=$((i + 1))
done
while kill -0 "${pids[@]}" 2>/dev/null; do
  for n in "${names[@]}"; do cp "runs/$n/metrics.jsonl" "$OUT/$n.metrics.jsonl" 2>/dev/null; done
  sleep 15
done
started=()  # a run its lane had no time for has no folder, log or metrics to report or pack
for n in "${names[@]}"; do [ -d "runs/$n" ] && started+=("$n"); done
names=(${started[@]+"${started[@]}"})
for n in "${names[@]}"; do
  cp "runs/$n/metrics.jsonl" "$OUT/$n.metrics.jsonl" 2>/dev/null
  echo "== $n"; [ -f "$OUT/$n.log" ] && tr '\r' '\n' < "$OUT/$n.log" | grep -v -i warp | grep -v '^\s*$' | tail -n 3
  python3 - "runs/$n" <<'PY'
import json, os, sys
for line in open(sys.argv[1] + "/metrics.jsonl"):
    d = json.loads(line)
    if "eval/nr" in d:
        extra = f"  stochastic {d['eval/stochastic_nr']:.3f}" if "eval/stochastic_nr" in d else ""
        print(f"  samples {d['step']:>11,}  wall {d['wall']:6.0f} s  NR {d['eval/nr']:.3f}"
              f"  paper {d['eval/nr_paper']:.3f}  falls {d['eval/fall_rate']:.2f}{extra}")
for grade in ("push.json", "push_cpu.json", "play_cpu.json"):  # grade_NAME's files
    path = os.path.join(sys.argv[1], grade)
    if os.path.isfile(path):
        d = json.load(open(path))
        keys = ("push_forward_n", "push_sideways_n", "nr", "nr_paper", "fall_rate")
        print(f"  {grade}: {({k: d[k] for k in keys if k in d})}")
PY
done
files=0; bytes=0
if [ -d /tmp/bench ]; then
  for f in /tmp/bench/*.log; do echo "== ${f##*/}"; grep -v -i warp "$f" | tail -n 8; done
  # cleared once packed: results of a call killed before this point come back with the next one
  tar czf "$OUT/bench.tgz" -C /tmp bench && rm -rf /tmp/bench; files=1; bytes=$(stat -c %s "$OUT/bench.tgz")
fi
if [ "${PACK:-}" = none ]; then  # one archive: $OUT brings back at most 8 files and 64 MiB
  policies=()  # at most six (35 MiB), each once: marked sent once packed, as the bench results
  for p in runs/*/policy.npz; do
    [ -f "$p" ] && [ ! -f "$p.sent" ] && [ ${#policies[@]} -lt 6 ] && policies+=("$p")
  done
  set -o pipefail
  tar czf - -C "$OUT" --files-from <(cd "$OUT" && ls ./*.log ./*.metrics.jsonl 2>/dev/null) \
    -C "$PWD" --files-from <(ls runs/*/*.json runs/*/*.log 2>/dev/null; printf '%s\n' ${policies[@]+"${policies[@]}"}) \
    | split -b 15M - "$OUT/logs.tgz." && rm -f "$OUT"/*.log "$OUT"/*.metrics.jsonl \
    && for p in ${policies[@]+"${policies[@]}"}; do touch "$p.sent"; done
  exit 0
fi
if [ "${PACK:-checkpoints}" != checkpoints ]; then
  # side by side (one after the other, five exports overran a call), each taking GPU memory as it
  # needs it (eleven at the run's memory fraction on one GPU: three failed)
  for n in "${names[@]}"; do
    (XLA_PYTHON_CLIENT_PREALLOCATE=false python3 -m mjxmimic.cli export "runs/$n" > /dev/null 2>&1 \
      || echo "export $n failed") &
  done
  wait
  keep_logs
  keep_best=(--exclude=best); [ "$PACK" = best ] && keep_best=()
  tar czf - --exclude=checkpoints --exclude=tb "${keep_best[@]}" runs | split -b 15M - "$OUT/policies.tgz."
  exit 0
fi
for d in runs/*/checkpoints; do  # keep the newest checkpoint only: what a resume needs
  ls -1 "$d" | sort -n | head -n -1 | while read -r old; do rm -rf "${d:?}/$old"; done
done
keep_logs
# one archive per run, in 15 MiB parts; $OUT brings back at most 8 files and 64 MiB, so a run
# that would not fit stays on the machine with the command that fetches it in a call of its own
for n in "${names[@]}"; do
  tar czf "/tmp/runs_$n.tgz" "runs/$n"
  size=$(stat -c %s "/tmp/runs_$n.tgz"); parts=$(( (size + 15728639) / 15728640 ))
  if [ $((files + parts)) -le 8 ] && [ $((bytes + size)) -le $((60 << 20)) ]; then
    split -b 15M "/tmp/runs_$n.tgz" "$OUT/runs_$n.tgz."; files=$((files + parts)); bytes=$((bytes + size))
  else
    echo "runs/$n ($((size >> 20)) MiB) left on the machine, over what comes back; fetch it next:" \
      "split -b 15M /tmp/runs_$n.tgz \$OUT/runs_$n.tgz."
  fi
done
