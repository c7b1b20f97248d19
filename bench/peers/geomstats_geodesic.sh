#!/usr/bin/env bash
# Peer comparison (run by hand, not in CI): geomstats' DiscreteSurfaces elastic-metric geodesic
# against qcshape on the same mesh pair (icosphere of 642 vertices to a twisted, stretched copy).
# Installs geomstats into a throwaway virtual environment, writes the pair with qcshape, times both
# and prints the ratio.
#   bash bench/peers/geomstats_geodesic.sh [LEVEL (3 = 642 vertices)] [NODES (10)]
set -euo pipefail
cd "$(dirname "$0")/../.."
level=${1:-3}
nodes=${2:-10}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p qcshape-cli
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q "geomstats==2.8.*" torch --extra-index-url https://download.pytorch.org/whl/cpu
# The pair, written by qcshape's demo geodesic (its end poses).
./target/release/qcshape geodesic --demo --steps $((nodes - 1)) --out "$work/path" --json > "$work/qcshape.json"
last=$(printf 'pose_%03d.ply' $((nodes - 1)))
cat > "$work/peer.py" <<PY
import json, time, sys
import numpy as np
import geomstats.backend as gs
from geomstats.geometry.discrete_surfaces import DiscreteSurfaces, ElasticMetric

def read_ply(path):
    # qcshape writes binary little-endian PLY; read with a tiny parser.
    data = open(path, 'rb').read()
    head, body = data.split(b'end_header\n', 1)
    nv = int([l for l in head.split(b'\n') if l.startswith(b'element vertex')][0].split()[-1])
    nf = int([l for l in head.split(b'\n') if l.startswith(b'element face')][0].split()[-1])
    v = np.frombuffer(body[:nv * 24], dtype='<f8').reshape(nv, 3)
    f = np.frombuffer(body[nv * 24:], dtype=np.dtype([('n', 'u1'), ('i', '<i4', 3)]), count=nf)['i']
    return v, f

a, faces = read_ply("$work/path/pose_000.ply")
b, _ = read_ply("$work/path/$last")
space = DiscreteSurfaces(faces=gs.array(faces))
space.equip_with_metric(ElasticMetric, a0=1, a1=1, b1=1, c1=1, d1=1, a2=1)
space.metric.exp_solver.n_steps = $nodes
t = time.time()
geod = space.metric.geodesic(initial_point=gs.array(a), end_point=gs.array(b))
geod(gs.linspace(0, 1, $nodes))
print(json.dumps({"seconds": time.time() - t}))
PY
peer=$("$work/venv/bin/python" "$work/peer.py" | tail -1)
python3 - "$work/qcshape.json" "$peer" <<'PY'
import json, sys
q = json.load(open(sys.argv[1])); p = json.loads(sys.argv[2])
print(f"qcshape  {q['seconds']:.3f} s  ({q['metric']}, {q['iterations']} its, converged {q['converged']})")
print(f"geomstats {p['seconds']:.3f} s  (elastic metric, default tolerance)")
print(f"ratio    {p['seconds'] / max(q['seconds'], 1e-9):.1f}x")
PY
