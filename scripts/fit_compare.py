"""Benchmark of the fit (issue 49; docs/fit.md): qs.fit against trimesh.registration.nricp_amberg
(default settings) and nearest-point projection on the same ground-truth inputs, at several target
resolutions, on a decimated (irregular) target and on scaled targets, one core each.

Commands (from the repository root; the venv needs numpy, scipy, rtree, trimesh, fast-simplification
and qcshape, e.g. `pip install numpy scipy rtree trimesh fast-simplification` and `maturin develop
--release` in crates/qcshape-py; these are the bench's own dependencies, not the CI's):

    for L in 4 5 6; do WRITE_DIR=/tmp/fitfix/l$L WRITE_ONLY=1 cargo run --release -p qcshape --example fit_accuracy -- $L; done
    RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 python scripts/fit_compare.py /tmp/fitfix

`--nricp-motions K` fits nricp on the first K motions only at level 6 (it is the slow one);
`--cases l4,l5` runs some cases only. The run prints two markdown tables.

Inputs (`crates/qcshape/examples/fit_accuracy.rs`, `crates/qcshape/tests/fit_fixture/mod.rs`): a
162-vertex template (rounded box on the level-2 icosphere) and, per motion (8 analytic
deformations at t = 1), the same shape deformed on a turned finer icosphere with Gaussian noise
(variance 1 % of the squared target edge), plus the true positions of the template's vertices.
The cases:
- l4, l5, l6: target icospheres of level 4, 5, 6 (2,562, 10,242, 40,962 vertices);
- l6-dec: the level-6 target decimated to a quarter of its faces (~10k vertices) by
  fast-simplification (quadric decimation): irregular triangles, unlike the icospheres;
- l4-x0.01, l4-x100: the level-4 case with template, target and truth all multiplied by 0.01 or
  100. The fixtures are posed (the target is the template's shape deformed in place) and nricp has
  no initial alignment, so the fair test of scale is the whole problem scaled: every method
  starts from the same posed template, and a scale-invariant method gives the errors of l4;
- l4-t0.01, l4-t100 (qs-sim only): the target and truth alone scaled, the template at unit size,
  which only a method with a similarity alignment can fit; qs-sim on l4 is its unscaled reference.

Methods: `qs` is qs.fit(alignment="none") (the fixture is posed; the default smooth prior),
`qs-arap` the same with prior="arap" (the default until 2026-12-06), `qs-sim` is qs.fit with its
default similarity alignment, `nricp` is nricp_amberg(template, target) with its defaults, `near`
snaps each template vertex to its closest target point. Measures, per case and method (means over
the motions fitted):
- `med`: the median over the template's vertices of the distance to the true position, averaged
  over the motions; `all`: the median over every vertex of every motion;
- `sym`: the mean symmetric surface distance (distances of the fitted vertices to the target and
  of the target vertices to the fitted surface, pooled, so dominated by the target's vertices);
- all distances in the (scaled) template's mean edge length;
- `flip`: fitted triangles whose normal points against the same triangle's normal in the true
  pose, summed over the motions;
- `s/fit`: wall-clock seconds per fit (the call only; inputs already in memory);
- `peak MB`: the peak resident memory (VmHWM, Linux) of a fresh Python process that imports the
  libraries, reads the case and runs this method on all its motions and nothing else; `+MB`: that
  peak minus the process's resident memory just before the first fit (after imports, reading and
  a warm-up fit to the 162-vertex template itself), i.e. what the method's fits added at their
  largest (Rust, C and Python allocations alike; memory freed by one fit and reused by the next
  counts once).
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

KINDS = ["Twist", "Bend", "Taper", "Stretch", "Bulge", "Shear", "Dent", "Ripple"]
CASES = ["l4", "l5", "l6", "l6-dec", "l4-x0.01", "l4-x100", "l4-t0.01", "l4-t100"]
METHODS = {"qs": "qs.fit", "qs-arap": "qs.fit arap", "qs-sim": "qs.fit sim.", "nricp": "nricp", "near": "nearest"}


def methods_of(case):
    if case.startswith("l4-t"):
        return ["qs-sim"]
    if case == "l4":
        return ["qs", "qs-arap", "qs-sim", "nricp", "near"]
    return ["qs", "qs-arap", "nricp", "near"]


def build_case(fix, case):
    """The case's arrays: template V, F and per motion target W, G and truth X."""
    import fast_simplification
    import qcshape as qs

    level = case.split("-")[0]
    d = Path(fix) / level
    VT, FT = qs.read_mesh(d / "template.ply")
    out = {"V": VT, "F": FT}
    for k in KINDS:
        W, G = qs.read_mesh(d / f"{k}-target.ply")
        X, _ = qs.read_mesh(d / f"{k}-truth.ply")
        if case.endswith("-dec"):
            W, G = fast_simplification.simplify(W, G, target_reduction=0.75)
        out[f"{k}-W"], out[f"{k}-G"], out[f"{k}-X"] = W, G, X
    if "-x" in case or "-t" in case:
        s = float(case.split("-")[1][1:])
        for k in KINDS:
            out[f"{k}-W"] = out[f"{k}-W"] * s
            out[f"{k}-X"] = out[f"{k}-X"] * s
        if "-x" in case:
            out["V"] = VT * s
    return out


def worker(npz, method, kinds, out):
    """Fits `method` to the motions `kinds` of the case in `npz`; writes the fits, the times and
    the memory to `out`. Run in a fresh process per (case, method)."""
    import qcshape as qs
    import trimesh
    from trimesh.registration import nricp_amberg

    c = np.load(npz)
    V, F = c["V"], c["F"]
    src = trimesh.Trimesh(V, F, process=False)
    targets = {k: (c[f"{k}-W"], c[f"{k}-G"]) for k in kinds}
    meshes = {k: trimesh.Trimesh(W, G, process=False) for k, (W, G) in targets.items()}

    def run(W, G, mesh):
        if method == "qs":
            return qs.fit(V, F, W, G, alignment="none")[0]
        if method == "qs-arap":
            return qs.fit(V, F, W, G, alignment="none", prior="arap")[0]
        if method == "qs-sim":
            return qs.fit(V, F, W, G)[0]
        if method == "nricp":
            return nricp_amberg(src, mesh)
        return trimesh.proximity.closest_point(mesh, V)[0]

    # A warm-up on the template itself (162 vertices): lazy imports and one-time set-up are
    # not counted in the time or in +MB.
    run(V, F, trimesh.Trimesh(V, F, process=False))
    rss0 = status_kb("VmRSS")
    res, secs = {}, {}
    for k in kinds:
        W, G = targets[k]
        t0 = time.perf_counter()
        X = run(W, G, meshes[k])
        secs[k] = time.perf_counter() - t0
        res[k] = np.asarray(X, dtype=float)
    # VmHWM: this process's peak resident memory (ru_maxrss would carry the parent's over exec).
    peak = status_kb("VmHWM")
    np.savez(out, **res)
    Path(str(out) + ".json").write_text(json.dumps({"secs": secs, "peak_kb": peak, "base_kb": rss0}))


def status_kb(key):
    return int(next(l for l in open("/proc/self/status") if l.startswith(key)).split()[1])


def mean_edge(V, F):
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    return np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1).mean()


def normals(X, F):
    return np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])


def measures(c, k, X, lbar):
    import trimesh

    # Measured in edge lengths (everything divided by lbar): trimesh's closest point has absolute
    # tolerances, which would otherwise change `sym` on the targets scaled by 0.01.
    F = c["F"]
    W, G, T = c[f"{k}-W"] / lbar, c[f"{k}-G"], c[f"{k}-X"] / lbar
    X = X / lbar
    err = np.linalg.norm(X - T, axis=1)
    tgt = trimesh.Trimesh(W, G, process=False)
    a = trimesh.proximity.closest_point(tgt, X)[1]
    b = trimesh.proximity.closest_point(trimesh.Trimesh(X, F, process=False), W)[1]
    sym = np.concatenate([a, b]).mean()
    flip = int((np.einsum("ij,ij->i", normals(X, F), normals(T, F)) < 0).sum())
    return err, sym, flip


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("fixtures")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--nricp-motions", type=int, default=len(KINDS))
    ap.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        npz, method, kinds, out = a.worker
        worker(npz, method, kinds.split(","), out)
        return
    import qcshape as qs
    import trimesh

    work = Path(a.fixtures) / "bench"
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, RAYON_NUM_THREADS="1", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    print(f"qcshape {getattr(qs, '__version__', '?')}, trimesh {trimesh.__version__}; one thread per process; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} (times depend on what else runs)", flush=True)
    rows, detail = [], []
    for case in a.cases.split(","):
        c = build_case(a.fixtures, case)
        npz = work / f"{case}.npz"
        np.savez(npz, **c)
        # Errors in the template's mean edge length at the truth's scale.
        lbar = mean_edge(c["V"], c["F"])
        if "-t" in case:
            lbar *= float(case.split("-")[1][1:])
        nv = np.mean([len(c[f"{k}-W"]) for k in KINDS])
        for m in methods_of(case):
            kinds = KINDS[: a.nricp_motions] if (m == "nricp" and case.startswith("l6")) else KINDS
            out = work / f"{case}-{m}.npz"
            subprocess.run([sys.executable, __file__, a.fixtures, "--worker", str(npz), m, ",".join(kinds), str(out)],
                           check=True, env=env)
            fits = np.load(out)
            info = json.loads(Path(str(out) + ".json").read_text())
            meds, alls, syms, flips = [], [], [], 0
            for k in kinds:
                err, sym, flip = measures(c, k, fits[k], lbar)
                meds.append(np.median(err))
                alls.append(err)
                syms.append(sym)
                flips += flip
            r = {
                "case": case, "targetV": nv, "method": m, "n": len(kinds), "med": np.mean(meds),
                "all": np.median(np.concatenate(alls)), "sym": np.mean(syms), "flip": flips,
                "s": np.mean(list(info["secs"].values())), "peak": info["peak_kb"] / 1024,
                "plus": (info["peak_kb"] - info["base_kb"]) / 1024,
            }
            rows.append(r)
            detail.append((case, m, dict(zip(kinds, meds))))
            print(f"{case} {m}: med {r['med']:.3f} sym {r['sym']:.3f} flip {flips} {r['s']:.2f} s/fit "
                  f"peak {r['peak']:.0f} MB (+{r['plus']:.0f})", file=sys.stderr, flush=True)
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    print()
    print("| target | target vertices | method | motions | med | all | sym | flip | s/fit | peak MB | +MB |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['case']} | {r['targetV']:,.0f} | {METHODS[r['method']]} | {r['n']} | {r['med']:.3f} | {r['all']:.3f} "
              f"| {r['sym']:.3f} | {r['flip']} | {r['s']:.2f} | {r['peak']:.0f} | {r['plus']:.0f} |")
    print()
    print("Median error per motion (template edge lengths):")
    print()
    print("| target | method | " + " | ".join(k.lower() for k in KINDS) + " |")
    print("|---|---|" + "---:|" * len(KINDS))
    for case, m, d in detail:
        print(f"| {case} | {METHODS[m]} | " + " | ".join(f"{d[k]:.3f}" if k in d else "-" for k in KINDS) + " |")


if __name__ == "__main__":
    main()
