"""Warnings through Python's warnings module, category qcshape.QcshapeWarning (issue 50, item 3),
for the CLI's conditions: regularizer share above one half (geodesic, dist, similarity_matrix,
ShapeSpace.pairwise_distances and ShapeSpace.similarity),
the solver's iteration limit, the metric's own warning (lam = 0 with a conformal metric)."""

import warnings

import numpy as np
import pytest

import qcshape as qs


def caught(call):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = call()
    return out, [str(x.message) for x in w if issubclass(x.category, qs.QcshapeWarning)]


def test_category_is_a_user_warning():
    assert issubclass(qs.QcshapeWarning, UserWarning)


def test_regularizer_share_warns_on_geodesic_and_dist(pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F, lam=100.0)
    g, msgs = caught(lambda: space.geodesic(VA, VB, steps=2))
    assert g.regularizer_share > 0.5
    assert len(msgs) == 1 and "L2 regularizer carries" in msgs[0] and "lower lam" in msgs[0]
    _, msgs = caught(lambda: space.dist(VA, VB, steps=2))
    assert any("L2 regularizer carries" in m for m in msgs)
    # Filterable like any warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error", qs.QcshapeWarning)
        with pytest.raises(qs.QcshapeWarning):
            space.dist(VA, VB, steps=2)


def test_conformal_advice_does_not_say_lower_lam(pair):
    VA, VB, F = pair
    g, msgs = caught(lambda: qs.ShapeSpace(F, metric="conformal", lam=100.0).geodesic(VA, VB, steps=2))
    assert g.regularizer_share > 0.5
    assert len(msgs) == 1 and "a lower lam raises the share instead of lowering it" in msgs[0]
    # Issue 60: one sentence, balanced parentheses.
    assert msgs[0].count("(") == msgs[0].count(")")


def test_no_warning_when_the_metric_dominates(pair):
    VA, VB, F = pair
    g, msgs = caught(lambda: qs.ShapeSpace(F, lam=1e-4).geodesic(VA, VB, steps=2))
    assert g.regularizer_share <= 0.5 and g.converged
    assert msgs == []


def test_similarity_matrix_warns_for_dominated_pairs(synthetic):
    _, msgs = caught(lambda: qs.similarity_matrix(synthetic[0:4], metric="isometric", steps=2, lam=100.0, progress=False))
    assert any("more than half of the energy for" in m for m in msgs)


def test_pairwise_distances_and_similarity_warn_for_dominated_pairs(pair):
    VA, VB, F = pair
    C = 0.5 * (VA + VB)
    space = qs.ShapeSpace(F, lam=100.0, steps=2)
    _, msgs = caught(lambda: space.pairwise_distances([VA, VB, C], progress=False))
    assert len(msgs) == 1 and "more than half of the energy for 3 of 3 pairs" in msgs[0] and "lower lam" in msgs[0]
    _, msgs = caught(lambda: space.similarity([[VA, C], [VB, VB], [C, VA]], progress=False))
    assert len(msgs) == 1 and "more than half of the energy for" in msgs[0]
    _, msgs = caught(lambda: qs.ShapeSpace(F, lam=1e-4, steps=2).pairwise_distances([VA, VB, C], progress=False))
    assert msgs == []


def test_lambda_zero_conformal_warns_at_construction(sphere):
    _, F = sphere
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        qs.ShapeSpace(F, metric="conformal", lam=0.0)
    # Issue 60: once (it was twice, in two wordings), as a QcshapeWarning, in Python's words.
    msgs = [str(x.message) for x in w]
    assert len(msgs) == 1 and issubclass(w[0].category, qs.QcshapeWarning), msgs
    assert "lam=0" in msgs[0] and "stretch=" in msgs[0] and "--stretch" not in msgs[0]


def test_an_unconverged_stop_warns(sphere):
    # A crumpled target (seeded vertex noise as large as the sphere) with both tolerances 0: the
    # default solver stops unconverged on some of these, at its iteration limit (1000 on this
    # small mesh) or because its line search finds no decrease at rounding (NoProgress), which
    # one on this platform's arithmetic (measured: conformal, noise 0.6 without the bending term
    # at the limit; noise 1.0 with it, NoProgress). Every unconverged stop warns and says which;
    # a converged one does not warn. (It was argmin's L-BFGS on the smooth pair, retired:
    # docs/log/solvers.md.)
    V, F = sphere
    rng = np.random.default_rng(0)
    unconverged = 0
    for noise in (0.6, 1.0):
        B = V + noise * rng.standard_normal(V.shape)
        for bending in (0.0, 1e-4):
            space = qs.ShapeSpace(F, metric="conformal", tolerance=0.0, energy_tolerance=0.0, bending=bending)
            g, msgs = caught(lambda: space.geodesic(V, B, steps=3))
            stop_msgs = [m for m in msgs if "solver stopped" in m]
            if g.converged:
                assert not stop_msgs, msgs
                continue
            unconverged += 1
            if g.stop == "MaxIterations":
                assert any("iteration limit after 1000 iterations" in m for m in stop_msgs), msgs
            else:
                assert g.stop == "NoProgress", g.stop
                assert any("stopped without converging" in m and "no step lowered" in m for m in stop_msgs), msgs
    assert unconverged > 0

def test_folding_faces_warn_with_the_python_keyword():
    # A vertex pushed through its ring folds 10 of the 480 hinges: the bending term carries
    # most of the energy, and the warning names bending=0 (the CLI's twin names --bending 0).
    V, F = qs.icosphere(2)
    B = V.copy()
    B[0] *= 0.6
    g, msgs = caught(lambda: qs.ShapeSpace(F).geodesic(V, B))
    assert g.converged
    assert len(msgs) == 1 and "10 of 480 hinges" in msgs[0] and "bending=0" in msgs[0], msgs
    _, msgs = caught(lambda: qs.ShapeSpace(F, bending=0).geodesic(V, B))
    assert msgs == []
