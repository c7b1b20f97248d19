"""The Python API follows its ecosystem: scikit-learn's estimator contract for the clusterings,
pickling (so objects travel to Dask workers), slicing, and a clean namespace."""

import pickle

import numpy as np
import pytest

import qcshape as qs

from conftest import FAST


def test_estimators_follow_scikit_learn(fast_matrix, synthetic):
    sklearn = pytest.importorskip("sklearn")
    from sklearn.base import clone
    from sklearn.model_selection import GridSearchCV  # noqa: F401 (import check)

    for cls in (qs.KMeans, qs.KMedoids):
        est = cls(n_clusters=8, n_init=20, random_state=0)
        assert est.get_params()["n_clusters"] == 8
        twin = clone(est)
        assert twin.get_params() == est.get_params() and twin is not est
        est.set_params(n_clusters=4)
        assert est.n_clusters == 4
        with pytest.raises(ValueError, match="not a parameter"):
            est.set_params(k=3)
        assert cls().n_clusters == 8  # scikit-learn's default, not 2
        labels = cls(n_clusters=8, n_init=20, random_state=0).fit(fast_matrix).labels_
        # A RandomState and a Generator are accepted (and give valid clusterings).
        for rs in (np.random.RandomState(0), np.random.default_rng(0)):
            other = cls(n_clusters=8, n_init=20, random_state=rs).fit_predict(fast_matrix)
            assert other.shape == labels.shape and other.max() < 8
        # predict on the fitted items' own distances gives back the fitted labels (up to ties),
        # and on new rows it works with their (m, n) distances.
        fitted = cls(n_clusters=8, n_init=20, random_state=0).fit(fast_matrix)
        again = fitted.predict(fast_matrix)
        assert np.mean(again == fitted.labels_) >= 0.9
        assert fitted.predict(fast_matrix[:3]).shape == (3,)
        with pytest.raises(ValueError, match="X"):
            fitted.predict(fast_matrix[:, :5])
        with pytest.raises(ValueError, match="not fitted"):
            cls().predict(fast_matrix)
        with pytest.raises(ValueError, match="random_state"):
            cls(random_state="zero").fit(fast_matrix)
        with pytest.raises(ValueError, match="n_clusters"):
            cls(n_clusters=0).fit(fast_matrix)
        assert "n_clusters=" in repr(cls())
    assert sklearn is not None


def test_kmedoids_predict_is_the_nearest_medoid(fast_matrix):
    km = qs.KMedoids(n_clusters=8, n_init=20, random_state=0).fit(fast_matrix)
    assert np.array_equal(km.predict(fast_matrix), np.argmin(fast_matrix[:, km.medoid_indices_], axis=1))


def test_shape_space_and_dataset_pickle(pair, synthetic):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="isometric", steps=4, lam=0.02)
    again = pickle.loads(pickle.dumps(space))
    assert again.metric == space.metric and again.steps == 4
    assert again.dist(V, B) == space.dist(V, B)
    ref = qs.ShapeSpace(F, reference=V, steps=2)
    assert pickle.loads(pickle.dumps(ref)).dist(V, B) == ref.dist(V, B)
    small = synthetic[0:3]
    back = pickle.loads(pickle.dumps(small))
    assert back.names == small.names and back.labels == small.labels
    assert np.array_equal(back[1], small[1])
    assert np.array_equal(back.faces, small.faces)


def test_dataset_slices(synthetic):
    n = len(synthetic)
    assert len(synthetic[0:1]) == 1
    assert synthetic[0:1].names == synthetic.names[:1]
    assert synthetic[::2].names == synthetic.names[::2]
    assert synthetic[-2:].labels == synthetic.labels[-2:]
    assert synthetic[5].shape == synthetic[5 - n].shape
    with pytest.raises(ValueError, match="no deformation"):
        synthetic[3:3]
    with pytest.raises(TypeError, match="integer or a slice"):
        synthetic["a"]
    D = qs.similarity_matrix(synthetic[0:4], progress=False, **FAST)
    assert D.shape == (4, 4)


def test_namespace_is_the_api():
    for leaked in ("np", "npt", "PipelineOptions"):
        assert not hasattr(qs, leaked), leaked
    assert set(qs.__all__) <= set(dir(qs))
