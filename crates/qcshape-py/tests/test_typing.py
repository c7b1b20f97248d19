"""The stubs (python/qcshape/__init__.pyi) pass `mypy --strict` on the README's Python example and
on the test suite's typical calls, checked against the installed package (issue 50, item 8)."""

import importlib.util
import subprocess
import sys
import textwrap

import pytest

from test_readme import python_blocks

# Typical calls of the test suite, typed as a user's script would be (checked by mypy, not run).
TYPICAL_CALLS = textwrap.dedent(
    '''
    from typing import Dict, List, Optional

    import numpy as np
    import qcshape as qs

    V, F = qs.icosphere(1)
    V2, F2, fields = qs.read_mesh("a.ply", point_data=True)
    shift: np.ndarray = fields["shift"]
    space = qs.ShapeSpace(F, "isometric", lam=0.01, steps=4)
    B = 1.1 * V
    d: float = space.dist(V, B)
    g = space.geodesic(V, B, steps=2)
    lengths: List[float] = g.segment_lengths
    log, r = space.log(V, B)
    mean = space.karcher_mean(np.stack([V, B]), max_iterations=5)
    pd = space.pairwise_distances(np.stack([V, B, mean]), threads=1, progress=False)
    counts: List[int] = []
    pd2 = space.pairwise_distances([V, B], progress=lambda stage, done, total: counts.append(done))
    moved = space.transfer([V, B], V)
    ds = qs.Dataset.synthetic(level=1)
    small = qs.Dataset([ds[0], ds[1]], F, names=["a", "b"], labels=["x", None])
    sub: qs.Dataset = ds[0:4]
    D = qs.similarity_matrix(ds, progress=False, metric="isometric", steps=2, threads=2)
    D2, details = qs.similarity_matrix(small, return_details=True, steps=2)
    share = details["regularizer_share"].max()
    maps = qs.motion_maps(ds, measure="normal", steps=2)
    c = qs.pair_contributions(ds, 0, "b", steps=2)
    km = qs.KMedoids(n_clusters=2, random_state=np.random.default_rng(0)).fit(D)
    kk = qs.KMeans(n_clusters=2, n_init=5).fit(ds, steps=2)
    kernel: Optional[np.ndarray] = kk.kernel_labels_
    labels = qs.KMeans(2).fit_predict(D)
    s: Dict[str, float] = qs.scores(ds.labels, labels)
    s2 = qs.scores(list(km.labels_), km.predict(D[:3]))
    X, stress = qs.mds(D, n_components=2, random_state=0)
    table = qs.settings()["steps"]["default"]
    qs.write_mesh("mid.ply", g.path[1], F, point_data={"shift": np.linalg.norm(g.path[1] - V, axis=1)})
    Vt, Ft = qs.icosphere(2)
    fitted, residual, quality = qs.fit(V, F, 1.2 * Vt, Ft, alignment="rigid", stages=3)
    worst: float = float(residual.max()) + float(quality["mean"])
    '''
)


def run_mypy(tmp_path, name, source):
    if importlib.util.find_spec("mypy") is None:
        pytest.skip("mypy is not installed (pip install mypy): the stubs' type check is skipped")
    script = tmp_path / f"{name}.py"
    script.write_text(source)
    # Run from tmp_path so that mypy finds qcshape as installed (site-packages), not a source tree.
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-error-summary", "--cache-dir", str(tmp_path / "cache"),
         script.name],
        cwd=tmp_path, capture_output=True, text=True,
    )
    assert out.returncode == 0, f"mypy --strict on {name}:\n{out.stdout}{out.stderr}"


def test_readme_python_example_passes_mypy_strict(tmp_path):
    run_mypy(tmp_path, "readme_example", "\n".join(python_blocks()))


def test_typical_calls_pass_mypy_strict(tmp_path):
    run_mypy(tmp_path, "typical_calls", TYPICAL_CALLS)
