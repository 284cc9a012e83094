#!/usr/bin/env bash
# The device calls of 2026-11-26 (sixth session) on a lent four-GPU host, after the warp-lang
# transfer and install, one lane per GPU (experiments/device_train.sh):
#   bash experiments/calls_s8_x4.sh 1 SECONDS   # both getups trained with 40 % of their episodes
#       # started from knocked-down states (issue 14); the throw with equal imitation and task
#       # weights (issue 15); the G1 run to 300 M (issue 18)
#   bash experiments/calls_s8_x4.sh 2 SECONDS   # the face-down getup again (seed 1, and 60 %);
#       # the throw and the G1 run resumed; beside them, on the host's CPUs, the recovery test of
#       # call 1's getups composed with the best composite's other experts
#   bash experiments/calls_s8_x4.sh 3 SECONDS   # the same for call 2's getups; every policy back
# Carried (ignored folders): .banks/knockdowns_v7_seed7_100.npz (`mjxmimic play composite_v7.npz
# --knockdowns 100 --force 1000 --seed 7 --save-states`), .experts/ (the best composite's experts: walk_still_noise,
# getup_facedown, getup_faceup_push), .g1/ (the G1's MJCF), .clips/ (with g1_run.txt).
set -u
export MJXMIMIC_CLIPS=$PWD/.clips MJXMIMIC_G1=$PWD/.g1
bank="--set env.start_states=.banks/knockdowns_v7_seed7_100.npz"
gfd="--clip getup_facedown --preset gpu --set run.total_samples=150000000 $bank"
push="--set env.events=push --set env.push_force_max_n=400 --set env.push_interval_jitter_s=1.0"
gfu="--clip getup_faceup --preset gpu $push --set env.reset_noise_rad=0.3 --set run.total_samples=100000000 $bank"
throw="--task throw --preset gpu --set task.imitation_weight=0.5 --set task.task_weight=0.5"
throw="$throw --set run.total_samples=250000000 --set run.eval_every=20000000"
throw="$throw --set run.checkpoint_every=20000000 --set run.eval_episodes=100"
g1="--character g1 --clip run --preset gpu --set run.total_samples=300000000"
walk=.experts/walk_still_noise.npz old_gfd=.experts/getup_facedown.npz old_gfu=.experts/getup_faceup_push.npz
recovery() {  # RUN ...: export them, then the combos' plays (well inside a call); back in recovery_CALL.tgz
  mkdir -p /tmp/rec
  for n in "$@"; do  # on the GPUs beside the lanes, taking memory as needed
    XLA_PYTHON_CLIENT_PREALLOCATE=false python3 -m mjxmimic.cli export "runs/$n" > "/tmp/rec/export_$n.txt" 2>&1 &
  done
  wait
  bash experiments/composite/device_recovery.sh /tmp/rec/$call 50 "${combos[@]}" > /tmp/rec/summary_$call.txt 2>&1
}
call=$1
case $call in
  1) PACK=none bash experiments/device_train.sh "$2" "gfd_b4|$gfd --set env.start_states_fraction=0.4" \
       "gfu_b4|$gfu --set env.start_states_fraction=0.4" "throw_w05|$throw" "g1_run300|$g1" ;;
  2) combos=("b4_gfd|$walk runs/gfd_b4 $old_gfu" "b4_gfu|$walk $old_gfd runs/gfu_b4"
             "b4_both|$walk runs/gfd_b4 runs/gfu_b4")
     recovery gfd_b4 gfu_b4 &
     PACK=none bash experiments/device_train.sh "$2" "gfd_b4_s1|$gfd --set env.start_states_fraction=0.4 --set run.seed=1" \
       "gfd_b6|$gfd --set env.start_states_fraction=0.6" "throw_w05|$throw" "g1_run300|$g1"
     wait; cat /tmp/rec/summary_2.txt; tar czf "$OUT/recovery_2.tgz" -C /tmp rec ;;
  3) combos=("b4s1_gfd|$walk runs/gfd_b4_s1 $old_gfu" "b4s1_both|$walk runs/gfd_b4_s1 runs/gfu_b4"
             "b6_gfd|$walk runs/gfd_b6 $old_gfu" "b6_both|$walk runs/gfd_b6 runs/gfu_b4")
     recovery gfd_b4_s1 gfd_b6 &  # call 1's runs were exported in call 2
     PACK=policies bash experiments/device_train.sh "$2" "gfu_b4_s1|$gfu --set env.start_states_fraction=0.4 --set run.seed=1" \
       "gfd_b4_s2|$gfd --set env.start_states_fraction=0.4 --set run.seed=2 --set run.total_samples=100000000" \
       "throw_w05|$throw" "g1_run300|$g1"
     wait; cat /tmp/rec/summary_3.txt; tar czf "$OUT/recovery_3.tgz" -C /tmp rec ;;
esac
