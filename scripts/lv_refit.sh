#!/usr/bin/env bash
# Issue 49 on the LV phantom cohort (docs/fit.md, "The LV phantom cohort re-triangulated"):
# the original data (one connectivity, carried by landmark splines) against every pose
# re-triangulated (each frame's own marching-cubes surface) and fitted with one template.
#
#   scripts/lv_refit.sh OUT [phantom options, e.g. --overlap]
#
# QCSHAPE names the binary (default target/release/qcshape). Writes OUT/P (cohort), OUT/R0
# (lv run on the cohort: original meshes in R0/meshes, R0/similarity.csv), OUT/M (per-frame
# surfaces), OUT/F + OUT/RF (world frame, default similarity alignment), OUT/T, OUT/ML, OUT/FL +
# OUT/RFL (every subject in its frame-0 landmark frame, then the default similarity alignment),
# and prints the agreement of each fitted matrix with the original
# (scripts/matrix_agreement.py) and the motion decomposition (examples/refit_motion, built if
# missing).
set -euo pipefail
out=${1:?usage: scripts/lv_refit.sh OUT [phantom options]}
shift
here=$(cd "$(dirname "$0")/.." && pwd)
Q=${QCSHAPE:-$here/target/release/qcshape}
motion=$here/target/release/examples/refit_motion
[ -x "$motion" ] || (cd "$here" && cargo build --release -p qcshape --example refit_motion)
mkdir -p "$out"
cd "$out"
t() { local s=$SECONDS; "$@"; echo "  ($((SECONDS - s)) s: ${*:1:3})" >&2; }
RUN=(--region whole --no-sweep)
t "$Q" lv phantom --out P "$@" >/dev/null
t "$Q" lv run P --out R0 "${RUN[@]}" 2>R0.log
t "$Q" lv mesh P --out M --region whole --per-frame >M.log
t "$Q" fit --template R0/meshes/subject01/pose000.ply --out F M/manifest.csv --sequence 2>F.log
t "$Q" lv run F/manifest.csv --out RF "${RUN[@]}" 2>RF.log
t "$Q" lv mesh P --out T --region whole --vertices 600 --landmark-frame >T.log
t "$Q" lv mesh P --out ML --region whole --per-frame --landmark-frame >ML.log
t "$Q" fit --template T/subject01/pose000.ply --out FL ML/manifest.csv --sequence 2>FL.log
t "$Q" lv run FL/manifest.csv --out RFL "${RUN[@]}" 2>RFL.log
for f in F FL; do
  echo "== $f: $(tail -1 $f.log)"
  awk -F, 'NR > 1 { n++; m += $4; if ($5 > p) p = $5; fl += $9; poor += ($14 == "true") }
    END { printf "quality: %d poses, mean distance %.4f, largest p95 %.4f, flipped %d, poor %d\n", n, m / n, p, fl, poor }' $f/quality.csv
  python3 "$here/scripts/matrix_agreement.py" R0/similarity.csv R$f/similarity.csv P/labels.csv
done
echo "== motion, world frame (F)"; "$motion" R0/meshes/manifest.csv F/manifest.csv
echo "== motion, landmark frame (FL, rigidly moved onto the original at frame 0)"
RIGID=1 "$motion" R0/meshes/manifest.csv FL/manifest.csv | grep -v "rotated by"
