#!/usr/bin/env bash
# The device calls of 2026-11-27 (thirteenth session) on a lent four-GPU host, after the
# warp-lang transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s15_x4.sh 1 SECONDS   # all start; runs stay on the machine
#   bash experiments/calls_s15_x4.sh 2 SECONDS   # all go on; then every run's best policy, its
#                                                # grades and logs back (policies.tgz.*)
# The question (issue 17): does a push curriculum (env.push_ramp_samples: pushes scaled from 0 to
# full force over the first N samples) keep the NR of push training within 0.02 of the runs
# without pushes, and what forces do the policies then survive? Pushes along the facing or to
# the sides (env.push_directions=table6) up to 1.5 x Table 6's larger force of the clip (the
# target), every 2 +- 1 s. Each lane: 100 M samples with the ramp over 50 M and the preset's pose
# termination (world positions; explicit since runs with pushes default to the root frame), then
# the same with the pose termination measured from the character's root
# (env.pose_termination_frame=root), so that a push off the reference's path does not end the
# training episode.
# Beside the lanes, the host's CPUs push-test (`mjxmimic play POLICY --push --json`, MuJoCo C)
# every run that is done, while at least GRADE_MIN seconds of the call are left.
# Call 1 ran this script's first version (commit 253b3e5), whose second run in each lane was 200 M
# samples with the ramp over 100 M (rcL, bcL, kcL, ccL: 11 to 15 M done, then dropped for the
# root-frame runs); call 2 ran this version.
# Carried (ignored folder): .clips/ (DeepMimic's motions).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips
call=$1 seconds=$2
deadline=$(( $(date +%s) + seconds ))
P="--preset gpu --set env.events=push --set env.push_directions=table6 --set env.push_interval_jitter_s=1.0"
short="--set run.total_samples=100000000 --set env.push_ramp_samples=50000000"
lane() {  # NAME CLIP FORCE: the two runs of one lane
  local args="--clip $2 $P --set env.push_force_max_n=$3"
  echo "$1|$args $short --set env.pose_termination_frame=world;${1}R|$args $short --set env.pose_termination_frame=root"
}

grade() {  # RUN: its best policy exported, then NR and the push test on MuJoCo C
  local run=runs/$1
  XLA_PYTHON_CLIENT_PREALLOCATE=false CUDA_VISIBLE_DEVICES=$2 python3 -m mjxmimic.cli export "$run" \
    > "$run/export.log" 2>&1 || return
  local test
  for test in play push; do
    local flags=(--json); [ $test = push ] && flags+=(--push)
    (OMP_NUM_THREADS=1 python3 -m mjxmimic.cli play "$run/policy.npz" "${flags[@]}" > "$run/${test}_cpu.json.part" \
      2> "$run/${test}_cpu.log" && mv "$run/${test}_cpu.json.part" "$run/${test}_cpu.json") &
  done
  wait
}

grader() {  # every run that is done and not yet graded, while GRADE_MIN s are left
  local gpu=0
  while [ $(( deadline - $(date +%s) )) -gt "${GRADE_MIN:-480}" ]; do
    for done in runs/*/eval.json; do
      [ -f "$done" ] || continue
      local name; name=$(basename "$(dirname "$done")")
      [ -e "runs/$name/grading" ] && continue
      touch "runs/$name/grading"
      grade "$name" $((gpu % 4)) &
      gpu=$((gpu + 1))
    done
    sleep 20
  done
  wait
}

grader > /dev/null 2>&1 &
grading=$!
PACK=none bash experiments/device_train.sh $(( seconds - 40 )) \
  "$(lane rc run 1080)" "$(lane bc backflip 660)" "$(lane kc spinkick 1035)" "$(lane cc cartwheel 705)"
while kill -0 $grading 2>/dev/null && [ $(( deadline - $(date +%s) )) -gt 30 ]; do sleep 5; done
for f in runs/*/push_cpu.json; do [ -f "$f" ] && echo "$f: $(head -c 400 "$f")"; done
[ "$call" = 2 ] || exit 0
exports=()
for run in runs/*/; do  # the runs not graded here: their best policy, to grade elsewhere
  [ -f "$run/policy.npz" ] && continue
  XLA_PYTHON_CLIENT_PREALLOCATE=false python3 -m mjxmimic.cli export "$run" > /dev/null 2>&1 &
  exports+=($!)
done
[ ${#exports[@]} -gt 0 ] && wait "${exports[@]}"
tar czf - --exclude=checkpoints --exclude=best --exclude=tb runs | split -b 15M - "$OUT/policies.tgz."
