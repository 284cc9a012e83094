#!/usr/bin/env bash
# The recovery test on the device host's CPUs, beside its training lanes: each composite composed
# from its experts (policy files, or run folders with or without an exported policy.npz) and played with --knockdowns
# N on MuJoCo C, seeds 0 and 1 side by side, one core each.
#   bash experiments/composite/device_recovery.sh OUTDIR N "NAME|WALK GETUP_FACEDOWN GETUP_FACEUP" ...
# Writes OUTDIR/recovery_NAME_seed{0,1}.json (mjxmimic play --json) and the compose lines.
set -u
out=$1 n=$2; shift 2
mkdir -p "$out"
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 JAX_PLATFORMS=cpu
for spec in "$@"; do
  name=${spec%%|*}
  (
    # shellcheck disable=SC2086
    python3 -m mjxmimic.cli compose ${spec#*|} --out "/tmp/C_$name.npz" > "$out/compose_$name.txt" 2>&1 || exit 1
    for seed in 0 1; do
      python3 -m mjxmimic.cli play "/tmp/C_$name.npz" --knockdowns "$n" --force 1000 --seed $seed --json \
        > "$out/recovery_${name}_seed$seed.json" 2> "$out/recovery_${name}_seed$seed.err" &
    done
    wait
  ) &
done
wait
for f in "$out"/recovery_*.json; do
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(sys.argv[1], d.get('recovery_rate'))" "$f" 2>/dev/null \
    || echo "$f: no result"
done
