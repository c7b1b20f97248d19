#!/usr/bin/env bash
# Every geodesic solver against the default, one core, one run per table (docs/log/solvers.md):
# `qcshape geodesic --demo --demo-level L --metric M --solver S --json -q`, default settings
# otherwise. Each solver first runs natively under a CPU-time cap of 10x the default's CPU seconds
# in the same case (at least CAP_FLOOR seconds; `ulimit -t`, so the cap does not depend on the
# load): iterations, CPU seconds, final energy, converged. A run that finished is then repeated
# under callgrind for its instruction count (repeatable whatever the load); a run that hit the cap
# is marked "capped" and not repeated. Ratios are against the default of the same case and run.
#
# Usage: bench/solver_study.sh [QCSHAPE] (env: LEVELS="3 4", METRICS="isometric conformal
# quasi-conformal", SOLVERS="..." (the first is the baseline), CALLGRIND=0 to skip the
# instruction counts, CALLGRIND_SOLVERS="..." to count them for these solvers only (default:
# all; the baseline is always counted), CAP_FLOOR=2 (seconds), EXTRA="..." for more flags on every run (e.g.
# "--bending 0"), INPUTS="A.obj B.obj" to solve between two meshes instead of the demo: LEVELS is
# then ignored)
set -uo pipefail
Q="${1:-target/release/qcshape}"
LEVELS="${LEVELS:-3 4}"
METRICS="${METRICS:-isometric conformal quasi-conformal}"
# The solvers of today; the study of 2026-12-07 (docs/log/solvers.md) also ran newton,
# gauss-newton, gauss-newton-direct, lbfgs and plain-lbfgs, retired since (a build from before
# their retirement runs them).
SOLVERS="${SOLVERS:-preconditioned hessian-kronecker pose-kronecker}"
CALLGRIND="${CALLGRIND:-1}"
CALLGRIND_SOLVERS="${CALLGRIND_SOLVERS:-$SOLVERS}"
CAP_FLOOR="${CAP_FLOOR:-2}"
EXTRA="${EXTRA:-}"
export RAYON_NUM_THREADS=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# native CAP ARGS...: prints "iterations cpu energy converged" or "capped cpu".
native() {
  local cap=$1; shift
  # shellcheck disable=SC2086
  ( ulimit -t "$cap"; exec /usr/bin/time -o "$tmp/time" -f "%U %S" "$Q" "$@" $EXTRA --json -q ) \
    >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  local cpu
  cpu=$(tail -1 "$tmp/time" 2>/dev/null | awk '{print $1 + $2}')
  if [ $rc -ne 0 ] || ! python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$tmp/out" 2>/dev/null; then
    echo "capped ${cpu:-$cap}"
    return
  fi
  python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
print(d["iterations"], sys.argv[2], repr(d["energy"]), "yes" if d["converged"] else "no(" + str(d["stop"]) + ")")
' "$tmp/out" "$cpu"
}

# instructions ARGS...: callgrind's "Collected" count of one run.
instructions() {
  # shellcheck disable=SC2086
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$Q" "$@" $EXTRA --json -q \
    2>&1 >/dev/null | awk '/Collected/ {print $NF}'
}

echo "| vertices | metric | solver | iterations | CPU s | x default CPU | instructions (1e9) | x default instr. | energy | energy - default's | converged |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
if [ -n "${INPUTS:-}" ]; then LEVELS=inputs; fi
for level in $LEVELS; do
  if [ "$level" = inputs ]; then
    # shellcheck disable=SC2206
    case_args=($INPUTS)
    nv=$("$Q" geodesic "${case_args[@]}" --max-iterations 1 --json -q 2>/dev/null |
      python3 -c 'import json, sys; print(json.load(sys.stdin)["vertices"])')
  else
    case_args=(--demo --demo-level "$level")
    nv=$((10 * 4 ** level + 2))
  fi
  for m in $METRICS; do
    base_cpu=""
    base_ins=""
    base_e=""
    for s in $SOLVERS; do
      args=(geodesic "${case_args[@]}" --metric "$m" --solver "$s")
      if [ -z "$base_cpu" ]; then
        cap=600
      else
        cap=$(python3 -c 'import math,sys; print(max(int(sys.argv[2]), math.ceil(10 * float(sys.argv[1]))))' "$base_cpu" "$CAP_FLOOR")
      fi
      read -r it cpu e conv <<<"$(native "$cap" "${args[@]}")"
      if [ "$it" = "capped" ]; then
        echo "| $nv | $m | $s | capped | > $cpu | > $(python3 -c 'import sys; print("%.1f" % (float(sys.argv[1]) / float(sys.argv[2])))' "$cpu" "$base_cpu") | - | - | - | - | no (CPU cap ${cap} s) |"
        continue
      fi
      ins="-"
      if [ "$CALLGRIND" = 1 ] && { [ -z "$base_cpu" ] || [[ " $CALLGRIND_SOLVERS " == *" $s "* ]]; }; then
        ins=$(instructions "${args[@]}")
      fi
      if [ -z "$base_cpu" ]; then
        base_cpu=$cpu
        base_ins=$ins
        base_e=$e
      fi
      python3 - "$nv" "$m" "$s" "$it" "$cpu" "$base_cpu" "$ins" "$base_ins" "$e" "$base_e" "$conv" <<'EOF'
import sys
nv, m, s, it, cpu, bcpu, ins, bins, e, be, conv = sys.argv[1:]
cpu, bcpu, e, be = float(cpu), float(bcpu), float(e), float(be)
if ins not in ("-", "") and bins not in ("-", ""):
    i, bi = int(ins.replace(",", "")), int(bins.replace(",", ""))
    ins_s, ratio_i = "%.2f" % (i / 1e9), "%.2f" % (i / bi)
else:
    ins_s, ratio_i = "-", "-"
ratio_c = "%.1f" % (cpu / bcpu) if bcpu >= 0.02 else "-"
print("| %s | %s | %s | %s | %.2f | %s | %s | %s | %.6g | %+.2e | %s |" % (
    nv, m, s, it, cpu, ratio_c, ins_s, ratio_i, e, e - be, conv))
EOF
    done
  done
done
