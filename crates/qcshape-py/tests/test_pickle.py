"""Every result object pickles (issue 50, item 6): Geodesic bit for bit, the fitted estimators,
Dataset and ShapeSpace; one Geodesic through a Dask worker."""

import pickle

import numpy as np
import pytest

import qcshape as qs

FIELDS = [
    "length", "energy", "initial_energy", "geometric_energy", "regularizer_energy", "regularizer_share",
    "segment_lengths", "iterations", "converged", "stop", "gradient_norm", "scale", "seconds",
]


def same_geodesic(a, b):
    np.testing.assert_array_equal(a.path, b.path)
    for f in FIELDS:
        assert getattr(a, f) == getattr(b, f), f
    assert repr(a) == repr(b)


def test_geodesic_round_trips(pair):
    VA, VB, F = pair
    g = qs.ShapeSpace(F).geodesic(VA, VB, steps=3)
    same_geodesic(pickle.loads(pickle.dumps(g)), g)


def test_every_result_pickles(pair, synthetic, fast_matrix):
    VA, VB, F = pair
    space = qs.ShapeSpace(F, metric="conformal")
    assert pickle.loads(pickle.dumps(space)).dist(VA, VB) == space.dist(VA, VB)
    ds = pickle.loads(pickle.dumps(synthetic))
    assert ds.names == synthetic.names
    for est in (qs.KMedoids(n_clusters=6, random_state=0), qs.KMeans(n_clusters=6, random_state=0)):
        fitted = est.fit(fast_matrix)
        back = pickle.loads(pickle.dumps(fitted))
        np.testing.assert_array_equal(back.labels_, fitted.labels_)


def _length_on_worker(g):
    return g.length, g.path.shape, g.stop


def test_geodesic_travels_through_a_dask_worker(pair):
    distributed = pytest.importorskip("distributed")
    VA, VB, F = pair
    g = qs.ShapeSpace(F).geodesic(VA, VB, steps=3)
    with distributed.Client(
        distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None)
    ) as client:
        back = client.submit(lambda: g).result()
        assert client.submit(_length_on_worker, g).result() == (g.length, g.path.shape, g.stop)
    same_geodesic(back, g)
