#!/usr/bin/env bash
# Issue 49 on the LV phantom cohort (docs/fit.md, "The LV phantom cohort re-triangulated"):
# the original data (one connectivity, carried by landmark splines) against every pose
# re-triangulated (each frame's own marching-cubes surface) and fitted with one template.
#
#   scripts/lv_refit.sh OUT [phantom options, e.g. --overlap]
#
# QCSHAPE names the binary (default target/release/qcshape), REFIT_MOTION the example
# refit_motion (default $CARGO_TARGET_DIR or target, /release/examples/refit_motion, built if
# missing). PRIOR names the fits' --prior (default: the CLI's default; docs/fit.md); with PRIOR
# set the fits and their analyses go to OUT/F-$PRIOR, OUT/RF-$PRIOR, OUT/FL-$PRIOR and
# OUT/RFL-$PRIOR, and the inputs already in OUT (P, R0, M, T, ML, from a run with the same
# phantom options) are kept, so that a second prior costs only its fits:
#   scripts/lv_refit.sh OUT --overlap && PRIOR=affine scripts/lv_refit.sh OUT --overlap
# FIT_ARGS adds arguments to every `qcshape fit` and TAG names the outputs (default: PRIOR),
# e.g. FIT_ARGS="--global-degree 2" TAG=deg2.
# Writes OUT/P (cohort), OUT/R0
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
motion=${REFIT_MOTION:-${CARGO_TARGET_DIR:-$here/target}/release/examples/refit_motion}
[ -x "$motion" ] || (cd "$here" && cargo build --release -p qcshape --example refit_motion)
PRIOR=${PRIOR:-}
FIT_ARGS=${FIT_ARGS:-}
TAG=${TAG:-$PRIOR}
sfx=${TAG:+-$TAG}
FIT=(${PRIOR:+--prior "$PRIOR"} $FIT_ARGS)
mkdir -p "$out"
cd "$out"
t() { local s=$SECONDS; "$@"; echo "  ($((SECONDS - s)) s: ${*:1:3})" >&2; }
# with TAG (or PRIOR) set, an input step whose output exists is kept (its log too)
kept() { [ -n "$TAG" ] && [ -e "$1" ] && echo "  (kept: $1)" >&2; }
RUN=(--region whole --no-sweep)
kept P/labels.csv || t "$Q" lv phantom --out P "$@" >/dev/null
kept R0/similarity.csv || t "$Q" lv run P --out R0 "${RUN[@]}" 2>R0.log
kept M/manifest.csv || t "$Q" lv mesh P --out M --region whole --per-frame >M.log
t "$Q" fit --template R0/meshes/subject01/pose000.ply --out F$sfx M/manifest.csv --sequence "${FIT[@]}" 2>F$sfx.log
t "$Q" lv run F$sfx/manifest.csv --out RF$sfx "${RUN[@]}" 2>RF$sfx.log
kept T/subject01/pose000.ply || t "$Q" lv mesh P --out T --region whole --vertices 600 --landmark-frame >T.log
kept ML/manifest.csv || t "$Q" lv mesh P --out ML --region whole --per-frame --landmark-frame >ML.log
t "$Q" fit --template T/subject01/pose000.ply --out FL$sfx ML/manifest.csv --sequence "${FIT[@]}" 2>FL$sfx.log
t "$Q" lv run FL$sfx/manifest.csv --out RFL$sfx "${RUN[@]}" 2>RFL$sfx.log
for f in F$sfx FL$sfx; do
  echo "== $f: $(tail -1 $f.log)"
  awk -F, 'NR > 1 { n++; m += $4; if ($5 > p) p = $5; fl += $9; poor += ($14 == "true"); if ($17 > sl) sl = $17 }
    END { printf "quality: %d poses, mean distance %.4f, largest p95 %.4f, flipped %d, poor %d, largest slide %.3f\n", n, m / n, p, fl, poor, sl }' $f/quality.csv
  python3 "$here/scripts/matrix_agreement.py" R0/similarity.csv R$f/similarity.csv P/labels.csv
done
echo "== motion, world frame (F$sfx)"; "$motion" R0/meshes/manifest.csv F$sfx/manifest.csv
echo "== motion, landmark frame (FL$sfx, rigidly moved onto the original at frame 0)"
RIGID=1 "$motion" R0/meshes/manifest.csv FL$sfx/manifest.csv | grep -v "rotated by"
