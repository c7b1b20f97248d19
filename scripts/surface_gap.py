"""How far apart two data sets' surfaces are, pose by pose (docs/fit.md, "The LV phantom cohort
re-triangulated"): the distance of every vertex of A's poses to the surface of B's pose with the
same deformation name and pose number (any triangulations), pooled over all poses, in the
data's length unit.

    python scripts/surface_gap.py A/manifest.csv B/manifest.csv

e.g. A = `lv run`'s R0/meshes (the original), B = `lv mesh --per-frame`'s M (the re-extracted
surfaces a fit sees). Needs numpy, trimesh and rtree (the bench's venv, see fit_compare.py)."""

import csv
import sys
from pathlib import Path

import numpy as np
import trimesh


def rows(manifest):
    p = Path(manifest)
    with open(p) as f:
        return {(r["deformation"], int(r["pose"])): p.parent / r["path"] for r in csv.DictReader(f)}


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: surface_gap.py A/manifest.csv B/manifest.csv")
    a, b = rows(sys.argv[1]), rows(sys.argv[2])
    missing = sorted(set(a) - set(b))
    if missing:
        sys.exit(f"{sys.argv[2]}: no pose for {missing[:3]}")
    d = []
    for key, path in sorted(a.items()):
        va = trimesh.load(path, process=False).vertices
        mb = trimesh.load(b[key], process=False)
        d.append(trimesh.proximity.closest_point(mb, va)[1])
    d = np.concatenate(d)
    print(f"{len(a)} poses, {len(d)} vertices: distance to the other surface rms {np.sqrt((d ** 2).mean()):.3f}, "
          f"mean {d.mean():.3f}, p95 {np.percentile(d, 95):.3f}, max {d.max():.3f}")


if __name__ == "__main__":
    main()
