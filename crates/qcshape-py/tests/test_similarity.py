"""The similarity matrix against the CLI's CSV, sklearn interoperation, clustering, MDS, scores."""

import csv
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import qcshape as qs
from conftest import FAST


def cli():
    """The built `qcshape` binary named by QCSHAPE_BIN (set by .ci/run), or a skip."""
    path = os.environ.get("QCSHAPE_BIN")
    if not path or not Path(path).is_file():
        pytest.skip("QCSHAPE_BIN is not set to the built qcshape binary (.ci/run sets it)")
    return path


def read_matrix_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = rows[0][1:]
    assert [r[0] for r in rows[1:]] == names
    return names, np.array([[float(x) for x in r[1:]] for r in rows[1:]])


@pytest.mark.parametrize(
    "args, kwargs",
    [
        (["--metric", "isometric", "--steps", "2"], dict(FAST)),
        (
            ["--metric", "quasi-conformal", "--steps", "2", "--insert", "1", "--transport", "parallel"],
            dict(metric="quasi-conformal", steps=2, insert=1, transport="parallel"),
        ),
        (
            ["--metric", "l2", "--steps", "2", "--align", "none", "--smooth", "0"],
            dict(metric="l2", steps=2, align="none", smooth=0),
        ),
    ],
)
def test_similarity_matrix_equals_the_cli_csv(tmp_path, args, kwargs):
    exe = cli()
    syn = tmp_path / "syn"
    subprocess.run([exe, "synth", "--out", str(syn), "--level", "1"], check=True, capture_output=True)
    manifest = syn / "manifest.csv"
    ds = qs.Dataset.from_manifest(manifest)
    if kwargs.get("insert"):
        # The slower settings on a subset: two deformation types on all six shapes.
        keep = [i for i, l in enumerate(ds.labels) if l in ("twist", "bulge")]
        rows = list(csv.reader(open(manifest, newline="")))
        names = {ds.names[i] for i in keep}
        sub = syn / "subset.csv"
        with open(sub, "w", newline="") as f:
            csv.writer(f).writerows([rows[0]] + [r for r in rows[1:] if r[0] in names])
        manifest, ds = sub, qs.Dataset.from_manifest(sub)
    out = tmp_path / "D.csv"
    subprocess.run(
        [exe, "similarity", str(manifest), *args, "--threads", "2", "-o", str(out)], check=True, capture_output=True
    )
    names, expected = read_matrix_csv(out)
    D = qs.similarity_matrix(ds, threads=1, progress=False, **kwargs)
    assert names == ds.names
    assert D.shape == expected.shape
    np.testing.assert_allclose(D, expected, rtol=0, atol=1e-12)


def test_the_matrix_does_not_depend_on_threads(synthetic, fast_matrix):
    D1 = qs.similarity_matrix(synthetic, threads=1, progress=False, **FAST)
    np.testing.assert_array_equal(D1, fast_matrix)
    np.testing.assert_array_equal(fast_matrix, fast_matrix.T)
    np.testing.assert_array_equal(np.diag(fast_matrix), 0.0)


def test_sklearn_nearest_neighbours_on_the_precomputed_matrix(synthetic, fast_matrix):
    from sklearn.model_selection import cross_val_score
    from sklearn.neighbors import KNeighborsClassifier

    y = np.array(synthetic.labels)
    knn = KNeighborsClassifier(n_neighbors=1, metric="precomputed")
    acc = cross_val_score(knn, fast_matrix, y, cv=3).mean()
    assert acc > 0.9, acc
    knn.fit(fast_matrix, y)
    assert (knn.predict(fast_matrix) == y).all()


def test_clustering_mds_and_scores(synthetic, fast_matrix):
    from sklearn.metrics import adjusted_rand_score

    y = synthetic.labels
    km = qs.KMedoids(n_clusters=8, n_init=20, random_state=0).fit(fast_matrix)
    labels = km.labels_
    assert labels.shape == (48,) and labels.dtype == np.int64
    assert len(km.medoid_indices_) == 8
    s = qs.scores(y, labels)
    assert set(s) == {"sensitivity", "specificity", "ari", "accuracy"}
    assert s["ari"] == pytest.approx(adjusted_rand_score(y, labels), abs=1e-12)
    assert s["sensitivity"] > 0.8 and s["specificity"] > s["sensitivity"] - 1e-12
    kernel = qs.KMeans(n_clusters=8, n_init=20, random_state=0).fit(fast_matrix)
    assert qs.scores(y, kernel.labels_)["accuracy"] > 0.8
    X, stress = qs.mds(fast_matrix, n_components=2, random_state=0)
    assert X.shape == (48, 2) and np.isfinite(stress) and stress > 0
    perfect = qs.scores(["a", "a", "b", "b", "c"], [2, 2, 0, 0, 1])
    assert perfect == {"sensitivity": 1.0, "specificity": 1.0, "accuracy": 1.0, "ari": 1.0}
    with pytest.raises(ValueError, match="^D"):
        qs.mds(fast_matrix[:3])
    with pytest.raises(ValueError):
        qs.KMedoids(n_clusters=100).fit(fast_matrix)


def test_intrinsic_kmeans_on_a_small_dataset(synthetic):
    twist = [i for i, l in enumerate(synthetic.labels) if l == "twist"]
    bend = [i for i, l in enumerate(synthetic.labels) if l == "bend"]
    keep = twist[:3] + bend[:3]
    ds = qs.Dataset(
        poses=[synthetic[i] for i in keep],
        faces=synthetic.faces,
        names=[synthetic.names[i] for i in keep],
        labels=[synthetic.labels[i] for i in keep],
    )
    assert len(ds) == len(keep) and ds.n_vertices == 42
    km = qs.KMeans(n_clusters=2, n_init=5, random_state=0).fit(ds, metric="isometric", steps=2, progress=False)
    assert km.labels_.shape == (len(keep),)
    assert km.distances_.shape == (len(keep), len(keep))
    assert qs.scores(ds.labels, km.labels_)["accuracy"] == 1.0
    with pytest.raises(TypeError, match="unexpected keyword"):
        qs.similarity_matrix(ds, metirc="l2")
    with pytest.raises(ValueError, match="^base"):
        qs.similarity_matrix(ds, base="nobody", progress=False)


def test_dataset_arguments_are_checked(synthetic):
    with pytest.raises(ValueError, match="^names"):
        qs.Dataset(poses=[synthetic[0], synthetic[1]], faces=synthetic.faces, names=["one"])
    with pytest.raises(ValueError, match=r"^poses\[1\]"):
        qs.Dataset(poses=[synthetic[0], synthetic[1][:, :10]], faces=synthetic.faces)
    with pytest.raises(ValueError, match="^dataset"):
        qs.similarity_matrix("syn/manifest.csv")
    with pytest.raises(OSError, match="nothing.csv"):
        qs.Dataset.from_manifest("/nonexistent/nothing.csv")


def test_pair_contributions_sum_to_the_matrix_entry(synthetic, fast_matrix):
    c = qs.pair_contributions(synthetic, 0, 2, progress=False, **FAST)
    assert c.shape == (synthetic.n_vertices,)
    assert c.dtype == np.float64
    assert np.all(c >= 0.0)
    assert abs(c.sum() - fast_matrix[0, 2]) <= 1e-6 * fast_matrix[0, 2]
    # By name, in either order: the same split.
    names = synthetic.names
    by_name = qs.pair_contributions(synthetic, names[2], names[0], progress=False, **FAST)
    np.testing.assert_allclose(by_name, c, rtol=1e-3, atol=1e-6 * c.max())
    with pytest.raises(ValueError, match="out of range"):
        qs.pair_contributions(synthetic, 0, 99, progress=False, **FAST)
    with pytest.raises(ValueError, match="no deformation named"):
        qs.pair_contributions(synthetic, 0, "nobody", progress=False, **FAST)


def test_motion_maps_are_signed_by_group_difference(synthetic):
    m = qs.motion_maps(synthetic, progress=False, **FAST)
    assert m.shape == (len(synthetic), synthetic.n_vertices)
    assert m.dtype == np.float64
    assert np.all(m >= 0.0) and np.all(np.isfinite(m))
    assert m.sum(axis=1).min() > 0.0
    share = qs.motion_maps(synthetic, scale="share", progress=False, **FAST)
    np.testing.assert_allclose(share.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(share, m / m.sum(axis=1, keepdims=True), rtol=1e-12)
    metric = qs.motion_maps(synthetic, measure="metric", progress=False, **dict(FAST, metric="l2"))
    assert metric.shape == m.shape and np.all(metric >= 0.0)
    with pytest.raises(ValueError, match="^measure"):
        qs.motion_maps(synthetic, measure="radial", progress=False)
    with pytest.raises(ValueError, match="^scale"):
        qs.motion_maps(synthetic, scale="relative", progress=False)
