"""qs.fit against trimesh.registration.nricp_amberg and nearest-point projection on the
ground-truth fixtures of the fit (issue 49; docs/fit.md), same inputs, same run, one core each.

    WRITE_DIR=/tmp/fitfix ALIGN=none cargo run --release -p qcshape --example fit_accuracy -- 4
    OMP_NUM_THREADS=1 RAYON_NUM_THREADS=1 python scripts/fit_compare.py /tmp/fitfix

The fixtures are posed (the target is the template's shape deformed in place), so both fits run
without an initial alignment (nricp_amberg has none; qs.fit with alignment="none"). Errors are
distances of each template vertex to its true position, in template mean edge lengths; `sym` is
the mean symmetric surface distance (fitted vertices to the target, target vertices to the
fitted surface), in the same unit. Needs numpy, scipy, trimesh and qcshape.
"""

import sys
import time
from pathlib import Path

import numpy as np
import trimesh
from trimesh.registration import nricp_amberg

import qcshape as qs

KINDS = ["Twist", "Bend", "Taper", "Stretch", "Bulge", "Shear", "Dent", "Ripple"]


def mean_edge(V, F):
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    return np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1).mean()


def sym(fitted, F, target):
    a = trimesh.proximity.closest_point(target, fitted)[1]
    b = trimesh.proximity.closest_point(trimesh.Trimesh(fitted, F, process=False), target.vertices)[1]
    return np.concatenate([a, b]).mean()


def main(folder):
    d = Path(folder)
    VT, FT = qs.read_mesh(d / "template.ply")
    lbar = mean_edge(VT, FT)
    src = trimesh.Trimesh(VT, FT, process=False)
    print(f"template {len(VT)} vertices; errors in template edge lengths ({lbar:.4f})")
    print(f"{'motion':<8} {'targetV':>7} | {'qs med':>7} {'qs sym':>7} {'qs s':>6} | {'nricp med':>9} {'nricp sym':>9} {'nricp s':>7} | {'near med':>8} | {'asap med':>8}")
    rows = []
    for k in KINDS:
        W, G = qs.read_mesh(d / f"{k}-target.ply")
        truth, _ = qs.read_mesh(d / f"{k}-truth.ply")
        tgt = trimesh.Trimesh(W, G, process=False)
        t0 = time.perf_counter()
        ours, _, _ = qs.fit(VT, FT, W, G, alignment="none")
        t_ours = time.perf_counter() - t0
        t0 = time.perf_counter()
        theirs = nricp_amberg(src, tgt)
        t_theirs = time.perf_counter() - t0
        asap, _, _ = qs.fit(VT, FT, W, G, alignment="none", prior="asap")
        near = trimesh.proximity.closest_point(tgt, VT)[0]
        err = lambda X: np.median(np.linalg.norm(X - truth, axis=1)) / lbar
        r = (err(ours), sym(ours, FT, tgt) / lbar, t_ours, err(theirs), sym(theirs, FT, tgt) / lbar, t_theirs, err(near), err(asap))
        rows.append(r)
        print(f"{k:<8} {len(W):>7} | {r[0]:>7.3f} {r[1]:>7.3f} {r[2]:>6.2f} | {r[3]:>9.3f} {r[4]:>9.3f} {r[5]:>7.2f} | {r[6]:>8.3f} | {r[7]:>8.3f}")
    m = np.mean(rows, axis=0)
    print(f"{'mean':<8} {'':>7} | {m[0]:>7.3f} {m[1]:>7.3f} {m[2]:>6.2f} | {m[3]:>9.3f} {m[4]:>9.3f} {m[5]:>7.2f} | {m[6]:>8.3f} | {m[7]:>8.3f}")


if __name__ == "__main__":
    main(sys.argv[1])
