#!/usr/bin/env bash
# Peer comparison (run by hand, not in CI): geomstats' DiscreteSurfaces elastic-metric geodesic
# (path straightening, scipy L-BFGS-B, torch backend) against qcshape on the same mesh pair: an
# icosphere to a copy twisted by 1.2 rad per unit height and stretched 1.5x (qcshape's --demo pair).
# Installs geomstats and torch from PyPI into a throwaway virtual environment, writes the pair
# with qcshape, times both on one core and prints the ratio.
#
#   bash bench/peers/geomstats_geodesic.sh [LEVEL (2 = 162, 3 = 642 vertices)] [NODES (10)]
#
# Environment: QC_METRIC (qcshape metric, default isometric), PEER_FTOL (L-BFGS-B ftol, default
# geomstats' 1e-3), PEER_MAXITER (default 15000), PEER_VENV (reuse a virtual environment).
# The two tools minimize different energies (geomstats' H2 elastic metric, qcshape's docs/method.md
# metrics): the figures compare solvers on one problem size, not one number.
set -euo pipefail
cd "$(dirname "$0")/../.."
level=${1:-3}
nodes=${2:-10}
metric=${QC_METRIC:-isometric}
ftol=${PEER_FTOL:-1e-3}
maxiter=${PEER_MAXITER:-15000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release -q -p qcshape-cli
venv=${PEER_VENV:-$work/venv}
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    # geomstats 2.8 imports numpy.trapz, removed in numpy 2.
    "$venv/bin/pip" install -q "geomstats==2.8.*" "numpy<2" torch
fi
# The pair, written by qcshape's demo geodesic (its end poses), and qcshape's own timing.
RAYON_NUM_THREADS=1 ./target/release/qcshape geodesic --demo --demo-level "$level" \
    --metric "$metric" --steps $((nodes - 1)) --out "$work/path" --json > "$work/qcshape.json"
last=$(printf 'pose%03d.ply' $((nodes - 1)))
cat > "$work/peer.py" <<PY
import json, os, time
os.environ["GEOMSTATS_BACKEND"] = "pytorch"
import numpy as np
import torch
torch.set_num_threads(1)
import geomstats.backend as gs
from geomstats.geometry.discrete_surfaces import DiscreteSurfaces, ElasticMetric
from geomstats.numerics.geodesic import PathStraightening
from geomstats.numerics.optimization import ScipyMinimize
from geomstats.numerics.path import UniformlySampledPathEnergy

def read_ply(path):
    # qcshape writes binary little-endian PLY: double x, y, z; uchar count + int indices.
    data = open(path, 'rb').read()
    head, body = data.split(b'end_header\n', 1)
    lines = head.split(b'\n')
    nv = int([l for l in lines if l.startswith(b'element vertex')][0].split()[-1])
    nf = int([l for l in lines if l.startswith(b'element face')][0].split()[-1])
    v = np.frombuffer(body[:nv * 24], dtype='<f8').reshape(nv, 3)
    f = np.frombuffer(body[nv * 24:], dtype=np.dtype([('n', 'u1'), ('i', '<i4', 3)]), count=nf)['i']
    return v.copy(), f.copy()

a, faces = read_ply("$work/path/pose000.ply")
b, _ = read_ply("$work/path/$last")
space = DiscreteSurfaces(faces=gs.array(faces.astype(np.int64)))
space.equip_with_metric(ElasticMetric, a0=1, a1=1, b1=1, c1=1, d1=1, a2=1)
opt = ScipyMinimize(method="L-BFGS-B", autodiff_jac=True,
                    options={"disp": False, "ftol": $ftol, "maxiter": $maxiter}, save_result=True)
space.metric.log_solver = PathStraightening(space, n_nodes=$nodes, optimizer=opt)
A, B = gs.array(a), gs.array(b)
line = gs.stack([A + t * (B - A) for t in gs.linspace(0.0, 1.0, $nodes)])
energy = UniformlySampledPathEnergy(space)
e_line = float(energy(line))
t = time.time()
geod = space.metric.geodesic(initial_point=A, end_point=B)
path = geod(gs.linspace(0.0, 1.0, $nodes))
sec = time.time() - t
res = opt.result_
print(json.dumps({"seconds": sec, "iterations": int(res.nit), "success": bool(res.success),
                  "message": str(res.message), "energy": float(energy(path.reshape(line.shape))),
                  "line_energy": e_line, "vertices": int(a.shape[0])}))
PY
peer=$("$venv/bin/python" "$work/peer.py" | tail -1)
python3 - "$work/qcshape.json" "$peer" "$ftol" <<'PY'
import json, sys
q = json.load(open(sys.argv[1])); p = json.loads(sys.argv[2])
print(f"pair: icosphere of {p['vertices']} vertices -> twisted 1.2 rad, stretched 1.5x; one core")
print(f"qcshape   {q['seconds']:9.3f} s  {q['metric']}, {q['iterations']} its, converged {q['converged']}, "
      f"energy {q['energy']:.6g} (line {q['linear_energy']:.6g})")
print(f"geomstats {p['seconds']:9.3f} s  elastic metric, L-BFGS-B ftol {sys.argv[3]}, {p['iterations']} its, "
      f"success {p['success']} ({p['message']}), energy {p['energy']:.6g} (line {p['line_energy']:.6g})")
print(f"ratio     {p['seconds'] / max(q['seconds'], 1e-9):9.1f}x")
PY
