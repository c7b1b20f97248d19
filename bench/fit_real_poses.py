"""Issue 59 item 3 (docs/fit.md, "Real poses: the horse gallop and the cactus"): the reference
pose of a captured or hand-posed motion fitted onto another pose of it, re-meshed, with the true
correspondence known (every pose of the motion shares the reference's connectivity), qcshape and
trimesh's nricp_amberg in the same run.

Data (not in this repository; pass the directories):
- horse gallop, 8,431 vertices, `0001.obj` ... `0048.obj` (github CraGL/Hyperspectral-Inverse-
  Skinning, commit c9ae7ad, models/horse-gallop; the copy repeats every 24 frames);
- cactus, 5,261 vertices, `cactus0.ply` ... `cactus18.ply` (github P4T0U/GOAST, commit 616dee8,
  data/cactus; cactus0 is the rest shape, the others are deformations of it).

Cases: the reference (horse frame 1, cactus0) is the template; each target pose (default horse
frames 6, 12, 18; cactus 4, 1, 17, about 5, 10 and 16 mean edge lengths of mean vertex motion),
and the reference itself as a check (`ref`: a fit onto its own surface re-meshed must be near 0),
is re-meshed so that no target vertex sits where a reference vertex should land:
- `decimate`: fast-simplification (quadric decimation, the library behind pyvista's
  `decimate`) to half the faces, about half the vertices;
- `remesh`: isotropic remeshing, gpytoolbox.remesh_botsch (target edge 1.25 x the pose's mean
  edge, 10 iterations, projected onto the pose), about two thirds of the vertices;
- `jitter` (option): the pose's own connectivity, every vertex slid a uniform random part (up to
  0.35) of the way to a random neighbour (the synthetic benchmark's meshing).

Methods (`--methods`): `none` = the reference pose itself, no fit (the baseline every fit must
beat); `qs` = qs.fit(reference, target) with its defaults (prior "smooth", similarity
alignment); `qs-affine` = qs.fit(..., prior="affine") (`qcshape fit --prior affine`);
`qs:KEY=VALUE+KEY=VALUE` = qs.fit(..., KEY=VALUE, ...) (e.g. `qs:prior=affine+alignment=none`,
`qs:max_samples=4000`); `nricp` = trimesh.registration.nricp_amberg(reference, target) with its
defaults (no alignment; its distance threshold 0.1 is absolute, in the data's units).

Columns, per fit: `med`, `p95` = median and 95th percentile over the reference's vertices of the
distance from the fitted vertex to its true position (the target pose's vertex of the same index),
in mean edge lengths of the reference pose; `nrm`, `tan` = medians of that error's part along the
true pose's vertex normal and in its tangent plane; `surf` = mean distance from the fitted
vertices to the re-meshed target surface (the fit lands on the surface when this is small, even
where `med` is large: a slide); `s` = seconds for the fit alone, one thread; `poor`, `slide` =
qs.fit's quality (docs/fit.md, "Quality"; not computed for nricp or none). Horse only:
`legs`, `head`, `body` = median error over the reference vertices in three regions of the
reference pose (legs and the lowest part of the belly: height y < 0.75; head and upper neck:
y >= 0.75 and z > 0.3; body: the rest, torso, lower neck and tail), to see where the error sits.
The summary closes with each method's mean over the poses (not `ref`) of the medians, per
subject and meshing.

Seeds are fixed (jitter: a hash of subject, pose and meshing); every method sees the same target.

    /work/venv-fit/bin/pip install trimesh rtree scipy fast-simplification gpytoolbox
    (cd crates/qcshape-py && maturin develop --release)
    RAYON_NUM_THREADS=1 OMP_NUM_THREADS=1 python bench/fit_real_poses.py \
        --horse /tmp/hc-data/horse --cactus /tmp/hc-data/cactus [--json out.json]

`--horse` or `--cactus` alone runs one subject; `--meshings`, `--methods`, `--horse-frames`,
`--cactus-poses` narrow or widen the run; `--report OUT.json` prints the tables of an earlier
`--json OUT.json` run again.
"""

import argparse
import json
import os
import sys
import time
import warnings
import zlib
from pathlib import Path

import numpy as np


# The meshes' reading, mean edge length and re-meshing (jitter, decimate, remesh) are the
# synthetic benchmark's (bench/fit_bench.py, beside this script).
sys.path.insert(0, str(Path(__file__).resolve().parent))
from fit_bench import mean_edge, mesh_target, read  # noqa: E402


def run_method(method, V, F, W, G):
    """(fitted vertices, seconds, quality dict or None)"""
    if method == "none":
        return V.copy(), 0.0, None
    if method == "nricp":
        import trimesh
        from trimesh.registration import nricp_amberg

        src = trimesh.Trimesh(V, F, process=False)
        tgt = trimesh.Trimesh(W, G, process=False)
        t0 = time.perf_counter()
        X = nricp_amberg(src, tgt)
        return np.asarray(X, float), time.perf_counter() - t0, None
    import qcshape as qs

    kw = {}
    if method.startswith("qs:"):
        for item in method[3:].split("+"):
            key, value = item.split("=", 1)
            kw[key] = int(value) if value.isdigit() else value
    elif method.startswith("qs-"):
        kw["prior"] = method[3:]
    elif method != "qs":
        raise ValueError(method)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a poor fit warns; the quality dict reports it
        X, _, q = qs.fit(V, F, W, G, **kw)
    return np.asarray(X, float), time.perf_counter() - t0, dict(q)


def horse_regions(V):
    legs = V[:, 1] < 0.75
    head = ~legs & (V[:, 2] > 0.3)
    return {"legs": legs, "head": head, "body": ~legs & ~head}


def measure(X, truth, F, W, G, h, regions):
    import trimesh

    d = X - truth
    err = np.linalg.norm(d, axis=1) / h
    n = trimesh.Trimesh(truth, F, process=False).vertex_normals
    dn = np.abs(np.einsum("ij,ij->i", d, n))
    dt = np.linalg.norm(d - np.einsum("ij,ij->i", d, n)[:, None] * n, axis=1)
    _, surf, _ = trimesh.proximity.closest_point(trimesh.Trimesh(W, G, process=False), X)
    out = {
        "med": float(np.median(err)),
        "p95": float(np.percentile(err, 95)),
        "nrm": float(np.median(dn) / h),
        "tan": float(np.median(dt) / h),
        "surf": float(np.mean(surf) / h),
    }
    for name, mask in (regions or {}).items():
        out[name] = float(np.median(err[mask]))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--horse", type=Path, help="directory of 0001.obj ... (horse gallop)")
    ap.add_argument("--cactus", type=Path, help="directory of cactus0.ply ... ")
    ap.add_argument("--horse-frames", default="6,12,18")
    ap.add_argument("--cactus-poses", default="4,1,17")
    ap.add_argument("--meshings", default="decimate,remesh")
    ap.add_argument("--methods", default="none,qs,qs-affine,nricp")
    ap.add_argument("--no-ref", action="store_true", help="skip the reference-onto-itself check")
    ap.add_argument("--json", type=Path, help="write every fit's numbers")
    ap.add_argument("--report", type=Path, help="print the tables of a --json file, no fit")
    a = ap.parse_args()
    if a.report is not None:
        rows = json.loads(a.report.read_text())
        report(rows, list(dict.fromkeys(r["method"] for r in rows)))
        return
    if a.horse is None and a.cactus is None:
        ap.error("give --horse DIR and/or --cactus DIR")
    for var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS"):
        if os.environ.get(var) != "1":
            print(f"note: {var} is not 1; the times are for one thread only when it is", file=sys.stderr)

    subjects = []
    if a.horse is not None:
        subjects.append(("horse", lambda k: a.horse / f"{int(k):04d}.obj", "1", a.horse_frames.split(",")))
    if a.cactus is not None:
        subjects.append(("cactus", lambda k: a.cactus / f"cactus{k}.ply", "0", a.cactus_poses.split(",")))
    meshings = a.meshings.split(",")
    methods = a.methods.split(",")
    rows = []
    for subject, path, ref, poses in subjects:
        V, F = read(path(ref))
        h = mean_edge(V, F)
        regions = horse_regions(V) if subject == "horse" else None
        print(f"{subject}: reference {path(ref).name}, {len(V)} vertices, mean edge {h:.5g}", file=sys.stderr)
        for pose in ([] if a.no_ref else ["ref"]) + poses:
            truth, Ft = read(path(ref if pose == "ref" else pose))
            if Ft.shape != F.shape or not (Ft == F).all():
                sys.exit(f"{subject} pose {pose}: connectivity differs from the reference's")
            for meshing in meshings:
                seed = zlib.crc32(f"{subject}/{pose}/{meshing}".encode())
                W, G = mesh_target(meshing, truth, F, seed)
                for method in methods:
                    X, t, q = run_method(method, V, F, W, G)
                    r = {"subject": subject, "pose": pose, "meshing": meshing, "target_vertices": len(W),
                         "method": method, "s": t}
                    r.update(measure(X, truth, F, W, G, h, regions))
                    if q is not None:
                        r["poor"] = bool(q["poor"])
                        r["slide"] = float(q["slide"])
                        r["quality"] = {k: (v if isinstance(v, (bool, int, float, str)) else str(v)) for k, v in q.items()}
                    rows.append(r)
                    print(f"  {subject} {pose} {meshing} ({len(W)} v) {method}: med {r['med']:.3f} p95 {r['p95']:.3f} "
                          f"nrm {r['nrm']:.3f} tan {r['tan']:.3f} surf {r['surf']:.3f} {t:.1f} s"
                          + (f" poor {r['poor']} slide {r['slide']:.3f}" if q is not None else ""),
                          file=sys.stderr, flush=True)
    report(rows, methods)
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


def report(rows, methods):
    cases = []
    for r in rows:
        key = (r["subject"], r["pose"], r["meshing"], r["target_vertices"])
        if key not in cases:
            cases.append(key)
    print("median (95th percentile) error in the reference's mean edge lengths; seconds per fit")
    print("| subject | pose | meshing (target vertices) | " + " | ".join(methods) + " | "
          + " | ".join(f"s {m}" for m in methods if m != "none") + " |")
    print("|---|---|---|" + "---:|" * (2 * len(methods) - ("none" in methods)))
    for key in cases:
        by = {r["method"]: r for r in rows if (r["subject"], r["pose"], r["meshing"], r["target_vertices"]) == key}
        print(f"| {key[0]} | {key[1]} | {key[2]} ({key[3]}) | "
              + " | ".join(f"{by[m]['med']:.2f} ({by[m]['p95']:.1f})" if m in by else "-" for m in methods) + " | "
              + " | ".join(f"{by[m]['s']:.1f}" if m in by else "-" for m in methods if m != "none") + " |")
    print()
    horse = any(r["subject"] == "horse" for r in rows)
    head = "| subject | pose | meshing (target vertices) | method | med | p95 | nrm | tan | surf | s | poor | slide |"
    if horse:
        head += " legs | head | body |"
    print(head)
    print("|" + "---|" * 4 + "---:|" * (head.count("|") - 5))
    for r in rows:
        line = (f"| {r['subject']} | {r['pose']} | {r['meshing']} ({r['target_vertices']}) | {r['method']} | "
                f"{r['med']:.3f} | {r['p95']:.3f} | {r['nrm']:.3f} | {r['tan']:.3f} | {r['surf']:.3f} | "
                f"{r['s']:.1f} | {r.get('poor', '-')} | " + (f"{r['slide']:.2f}" if "slide" in r else "-") + " |")
        if horse:
            line += "".join(f" {r[k]:.2f} |" if k in r else " - |" for k in ("legs", "head", "body"))
        print(line)
    print("\nmean over the poses (not ref) of the per-fit median error, and of the time:")
    timed = [m for m in methods if m != "none"]
    print("| subject | meshing | " + " | ".join(methods) + " | " + " | ".join(f"s {m}" for m in timed) + " |")
    print("|---|---|" + "---:|" * (len(methods) + len(timed)))
    for subject, meshing in dict.fromkeys((r["subject"], r["meshing"]) for r in rows):
        sel = [r for r in rows if r["subject"] == subject and r["meshing"] == meshing and r["pose"] != "ref"]
        med = [np.mean([r["med"] for r in sel if r["method"] == m]) for m in methods]
        sec = [np.mean([r["s"] for r in sel if r["method"] == m]) for m in timed]
        print(f"| {subject} | {meshing} | " + " | ".join(f"{x:.3f}" for x in med) + " | "
              + " | ".join(f"{x:.1f}" for x in sec) + " |")


if __name__ == "__main__":
    main()
