"""qcshape: deformation similarity in quasi-conformal shape space.

A Python layer over the qcshape Rust library (numpy arrays in and out):

    import qcshape as qs
    V, F = qs.read_mesh("pose000.ply")                     # float64 (nV, 3), int64 (nF, 3)
    V, F, fields = qs.read_mesh("scan.vtu", point_data=True)  # + {"name": (nV,) or (nV, k)}
    space = qs.ShapeSpace(F, metric="isometric", lam=0.01)
    g = space.geodesic(VA, VB, steps=8)                  # g.length, g.path (9, nV, 3), ...
    ds = qs.Dataset.from_manifest("syn/manifest.csv")
    D = qs.similarity_matrix(ds, metric="isometric")   # (n, n), as `qcshape similarity`
    D, details = qs.similarity_matrix(ds, return_details=True)  # + per-pair, per-pose distances
                                                         # and energy split (regularizer_share)
    labels = qs.KMedoids(n_clusters=8, n_init=20, random_state=0).fit(D).labels_
    X, stress = qs.mds(D, n_components=2, random_state=0)
    qs.scores(ds.labels, labels)                         # sensitivity, specificity, ari, accuracy
    space.dist(trimesh_a, trimesh_b)                     # mesh objects wherever V or F go:
    qs.ShapeSpace(pyvista_mesh); qs.to_trimesh(V, F)     # trimesh, pyvista, meshio (qs.as_arrays)
    V, residual, quality = qs.fit(VT, FT, scan_V, scan_F)  # template fitted to any triangulation

Every computation releases the GIL and stops at Ctrl-C (KeyboardInterrupt). Long calls take
progress=: None (the default) shows a bar on a terminal or in Jupyter (tqdm's when tqdm is
installed) and plain lines at most every 10 s in a log; True also logs each stage's last count;
False shows nothing; a callable receives (stage, done, total). Warnings (regularizer share, solver limits) are
qcshape.QcshapeWarning, a UserWarning, through the warnings module. Results pickle. Bad arguments raise ValueError naming
the argument; unreadable files OSError, invalid files ValueError with the file name and line.
"""

from ._qcshape import (
    METRICS,
    TERMS,
    Dataset,
    Geodesic,
    QcshapeWarning,
    ShapeSpace,
    fit,
    icosphere,
    mds,
    motion_maps,
    pair_contributions,
    read_mesh,
    scores,
    settings,
    similarity_matrix,
    write_mesh,
)
from ._meshes import as_arrays, to_meshio, to_pyvista, to_trimesh
from .cluster import KMeans, KMedoids

__all__ = [
    "METRICS",
    "TERMS",
    "Dataset",
    "Geodesic",
    "KMeans",
    "KMedoids",
    "QcshapeWarning",
    "ShapeSpace",
    "as_arrays",
    "fit",
    "icosphere",
    "mds",
    "motion_maps",
    "pair_contributions",
    "read_mesh",
    "scores",
    "settings",
    "similarity_matrix",
    "to_meshio",
    "to_pyvista",
    "to_trimesh",
    "write_mesh",
]
__version__ = "0.1.0"
