"""Cohort benchmark (issue 19): time and memory of the similarity matrix for growing cohorts of
synthetic left ventricles, exact and approximate, 1 and 2 threads, and a Dask LocalCluster.

Not a test: it prints a Markdown table and writes bench/results/cohort.csv. Run it with the
Python package installed (scripts/test builds one; or `pip install ./crates/qcshape-py[dask]`):

    python bench/cohort.py --sizes 25,50,100,200 --level 4 --exact-sizes 25 --out bench/results

Every configuration runs in a fresh child process, so that the peak resident memory
(`VmHWM`) is that configuration's own (with Dask: the client process only, not the workers).
The cohort: prolate spheroids on an icosphere of `--level` (4: 2,562 vertices), 8 frames of a
contraction cycle (radial contraction, long-axis shortening, twist), controls and a hypokinetic group (a free-wall sector moves 60 % less),
each subject in its own random pose (up to 20 degrees, a few mm) with vertex noise. Seeded.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def cohort(n: int, level: int, frames: int, seed: int):
    import qcshape as qs

    v0, faces = qs.icosphere(level)
    rng = np.random.default_rng(seed)
    poses_all, names, labels = [], [], []
    for s in range(n):
        hcm = s % 2 == 1
        a, c = rng.uniform(0.9, 1.1), rng.uniform(1.6, 2.0)
        amp, short, twist = rng.uniform(0.25, 0.35), rng.uniform(0.10, 0.16), rng.uniform(0.15, 0.3)
        theta = np.arctan2(v0[:, 1], v0[:, 0])
        sector = np.exp(-((np.angle(np.exp(1j * (theta - np.pi)))) ** 2) / 0.5)
        weight = 1.0 - (0.6 * sector if hcm else 0.0)
        ang = np.deg2rad(rng.uniform(-20, 20, 3))
        cx, cy, cz = np.cos(ang)
        sx, sy, sz = np.sin(ang)
        rot = (
            np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
            @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        )
        shift = rng.uniform(-0.2, 0.2, 3)
        seq = []
        for k in range(frames):
            phase = np.sin(np.pi * k / frames) ** 2
            r = 1.0 - amp * weight * phase
            x, y, z = v0[:, 0] * a * r, v0[:, 1] * a * r, v0[:, 2] * c * (1.0 - short * phase)
            t = twist * phase * v0[:, 2]
            p = np.column_stack([x * np.cos(t) - y * np.sin(t), x * np.sin(t) + y * np.cos(t), z])
            p = p + rng.normal(0.0, 0.004, p.shape)
            seq.append(p @ rot.T + shift)
        poses_all.append(np.array(seq))
        names.append(f"subject{s:04d}")
        labels.append("hcm" if hcm else "control")
    return qs.Dataset(poses_all, faces, names=names, labels=labels)


def child(args) -> None:
    """One configuration, in this process: prints a JSON line."""
    import resource

    import qcshape as qs

    ds = cohort(args.n, args.level, args.frames, args.seed)
    opts = dict(approx=args.approx, progress=False, metric=args.metric)
    if args.steps:
        opts["steps"] = args.steps
    t0 = time.perf_counter()
    if args.dask:
        import distributed

        import qcshape.dask

        with distributed.LocalCluster(
            n_workers=args.threads, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
        ) as cluster, distributed.Client(cluster) as client:
            t0 = time.perf_counter()
            d = qcshape.dask.similarity_matrix(ds, client=client, batch_size=args.batch, **opts)
    else:
        d = qs.similarity_matrix(ds, threads=args.threads, **opts)
    seconds = time.perf_counter() - t0
    np.save(args.matrix, d)
    # VmHWM (peak resident set of this process since its exec; ru_maxrss survives exec on Linux
    # and would report the parent's peak).
    rss_mb = float("nan")
    try:
        with open("/proc/self/status") as f:
            rss_mb = next(int(line.split()[1]) for line in f if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration):
        rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps(dict(seconds=seconds, rss_mb=rss_mb)))


def agreement(exact: np.ndarray, approx: np.ndarray, labels):
    from scipy.stats import spearmanr  # scikit-learn brings scipy
    from sklearn.cluster import SpectralClustering
    from sklearn.metrics import adjusted_rand_score

    iu = np.triu_indices(len(exact), 1)
    e, a = exact[iu], approx[iu]
    rel = np.abs(a - e) / np.where(e > 0, e, np.inf)
    nn = lambda d: np.argmin(d + np.diag(np.full(len(d), np.inf)), axis=1)  # noqa: E731
    lab = np.asarray(labels)
    agree = float(np.mean(lab[nn(exact)] == lab[nn(approx)]))

    def clusters(d):
        sigma = np.median(d[iu])
        return SpectralClustering(2, affinity="precomputed", random_state=0).fit_predict(np.exp(-((d / sigma) ** 2)))

    return dict(
        spearman=float(spearmanr(e, a)[0]),
        max_rel=float(rel.max()),
        nn_agreement=agree,
        ari=float(adjusted_rand_score(clusters(exact), clusters(approx))),
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", default="25,50,100,200")
    p.add_argument("--exact-sizes", default="25", help="sizes at which the exact matrix is computed too")
    p.add_argument("--level", type=int, default=4, help="icosphere level (4: 2,562 vertices)")
    p.add_argument("--frames", type=int, default=8)
    p.add_argument("--threads", default="1,2")
    p.add_argument("--dask", action="store_true", help="also a LocalCluster with 2 workers (straight mode)")
    p.add_argument("--batch", type=int, default=None, help="Dask pairs per task (default: qcshape.dask's choice)")
    p.add_argument(
        "--straight-steps", type=int, default=1, help="segments of the straight paths (exact: the default 8)"
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--metric", default="isometric", help="the library default (isometric since 2026-12-04)")
    p.add_argument("--modes", default="straight", help="approximate modes: straight and/or tangent (every metric)")
    p.add_argument("--out", default="bench/results")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--n", type=int, help=argparse.SUPPRESS)
    p.add_argument("--approx", default="straight", help=argparse.SUPPRESS)
    p.add_argument("--steps", type=int, default=0, help=argparse.SUPPRESS)
    p.add_argument("--matrix", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        args.threads = int(args.threads)
        child(args)
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sizes = [int(x) for x in args.sizes.split(",")]
    exact_sizes = {int(x) for x in args.exact_sizes.split(",") if x}
    rows = []

    def run(n, approx, threads, dask=False):
        matrix = out / f"D_{n}_{approx}_{threads}{'_dask' if dask else ''}.npy"
        cmd = [sys.executable, __file__, "--child", "--n", str(n), "--approx", approx, "--threads", str(threads)]
        cmd += ["--level", str(args.level), "--frames", str(args.frames), "--seed", str(args.seed)]
        cmd += ["--metric", args.metric]
        cmd += ["--matrix", str(matrix)] + (["--batch", str(args.batch)] if args.batch else []) + (["--dask"] if dask else [])
        if approx == "straight":
            cmd += ["--steps", str(args.straight_steps)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
        res = json.loads(r.stdout.strip().splitlines()[-1])
        pairs = n * (n - 1) // 2
        row = dict(
            n=n,
            mode={"straight": f"straight-{args.straight_steps}", "exact": "exact-8"}.get(approx, approx)
            + (" (dask, 2 workers)" if dask else ""),
            threads=threads,
            seconds=res["seconds"],
            rss_mb=res["rss_mb"],
            pairs_per_s=pairs / res["seconds"],
        )
        rows.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
        return np.load(matrix)

    labels = ["hcm" if s % 2 else "control" for s in range(max(sizes))]
    agreements = {}
    modes = args.modes.split(",")
    for n in sizes:
        for t in [int(x) for x in args.threads.split(",")]:
            approx = {m: run(n, m, t) for m in modes}
            if n in exact_sizes:
                d_exact = run(n, "exact", t)
                for m, d in approx.items():
                    agreements[(n, m)] = agreement(d_exact, d, labels[:n])
        if args.dask:
            run(n, modes[0], 2, dask=True)

    with open(out / "cohort.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    # Growth (straight, 2 threads): seconds = a N + b N(N-1)/2, the per-deformation preparation
    # (smoothing, alignment, transfer) and the pairs, fitted by least squares.
    first = {"straight": f"straight-{args.straight_steps}"}.get(modes[0], modes[0])
    fit = [(r["n"], r["n"] * (r["n"] - 1) / 2, r["seconds"]) for r in rows if r["mode"] == first and r["threads"] == 2]
    n_, pairs_, secs = np.array(fit).T
    if len(fit) >= 2:
        (per_def, per_pair), *_ = np.linalg.lstsq(np.column_stack([n_, pairs_]), secs, rcond=None)
    else:
        per_def, per_pair = 0.0, float(secs[0] / pairs_[0])
    import qcshape as qs

    nv = len(qs.icosphere(args.level)[0])
    # Projection: 1,000 subjects x 25 frames x 2,500 vertices; the cost of a pair grows with
    # the non-identical poses (frames - 1) and, linearly, with the vertices.
    scale = 2500 / nv
    proj = per_pair * (1000 * 999 / 2) * (24 / (args.frames - 1)) * scale + per_def * 1000 * (25 / args.frames) * scale
    print(f"\n{args.metric}; {nv} vertices, {args.frames} frames per subject; seed {args.seed}\n")
    print("| N | mode | threads | seconds | peak RSS MB | pairs/s |\n|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['n']} | {r['mode']} | {r['threads']} | {r['seconds']:.2f} | {r['rss_mb']:.0f} | {r['pairs_per_s']:.1f} |"
        )
    print(
        f"\n{first}, 2 threads: {per_pair * 1e3:.2f} ms per pair and {per_def * 1e3:.1f} ms per deformation "
        "(least-squares fit of seconds = a N + b N(N-1)/2)"
    )
    print(
        f"projection to 1,000 subjects x 25 frames x 2,500 vertices: {proj / 3600:.2f} h on 2 cores "
        f"({first}; pairs scaled by 24/{args.frames - 1} poses and 2,500/{nv} vertices)"
    )
    for (n, m), a in agreements.items():
        print(
            f"N = {n}: {m} vs exact: Spearman {a['spearman']:.5f}, max rel. error {100 * a['max_rel']:.3f} %, "
            f"1-NN agreement {a['nn_agreement']:.3f}, ARI (spectral, 2 clusters) {a['ari']:.3f}"
        )


if __name__ == "__main__":
    main()
