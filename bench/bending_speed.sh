#!/usr/bin/env bash
# The twisted sphere's default geodesic against the previous forms, one core, one run
# (docs/speed.md): `qcshape geodesic --demo --demo-level L --metric M` with the default (invariant
# scale, bending 1e-4), without the bending term (--bending 0; 642 and 2,562 vertices only: at
# 10,242 it takes minutes) and at the calibrated releases' form (--scale calibrated --stretch 0).
# Prints a markdown table: iterations and seconds of each. Usage: bench/bending_speed.sh [QCSHAPE]
set -euo pipefail
Q="${1:-target/release/qcshape}"
export RAYON_NUM_THREADS=1
# Seconds are the process's CPU time (user + system, one thread): on a shared machine the wall
# time also counts the waits for the core.
run() {
  local level=$1; shift
  local out cpu
  out=$( { /usr/bin/time -f "%U %S" "$Q" geodesic --demo --demo-level "$level" --json -q "$@" 2>/tmp/bending_speed.$$ ; } )
  cpu=$(tail -1 /tmp/bending_speed.$$ | awk '{print $1 + $2}')
  rm -f /tmp/bending_speed.$$
  python3 -c '
import json, sys
d = json.loads(sys.stdin.read())
print("%d it, %.2f s%s" % (d["iterations"], float(sys.argv[1]), "" if d["converged"] else " (not converged)"))
' "$cpu" <<<"$out"
}
echo "| vertices | metric | default (bending 1e-4) | --bending 0 | --scale calibrated --stretch 0 |"
echo "|---|---|---|---|---|"
for level in 3 4 5; do
  nv=$((10 * 4 ** level + 2))
  for m in isometric conformal quasi-conformal; do
    def=$(run "$level" --metric "$m")
    if [ "$level" -lt 5 ]; then nob=$(run "$level" --metric "$m" --bending 0); else nob="(docs/log/scale-invariant.md)"; fi
    cal=$(run "$level" --metric "$m" --scale calibrated --stretch 0)
    echo "| $nv | $m | $def | $nob | $cal |"
  done
done
