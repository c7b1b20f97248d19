"""ShapeSpace: distances, geodesics, log, transport, transfer, interpolation, bad arguments,
threads."""

import inspect
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import qcshape as qs


def test_dist_of_a_shape_to_itself_is_zero(pair):
    V, B, F = pair
    for metric in qs.METRICS:
        space = qs.ShapeSpace(F, metric=metric, steps=2)
        assert space.dist(B, B) == 0.0
        assert space.dist(V, B) > 0.0


def test_metrics_is_the_registry(pair):
    # qs.METRICS is the library's registry: the names metric= accepts, as the errors list them;
    # the default is one of them; the terms have distinct names.
    F = pair[2]
    assert qs.METRICS == ("l2", "rigid", "isometric", "conformal", "quasi-conformal")
    assert qs.settings()["metric"]["default"] in qs.METRICS
    assert len(set(qs.TERMS)) == len(qs.TERMS) and "bending" in qs.TERMS
    with pytest.raises(ValueError, match="expected " + ", ".join(qs.METRICS)):
        qs.ShapeSpace(F, metric="bogus")


def test_geodesic_is_symmetric(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="isometric", lam=0.1, steps=4, reference=V, tolerance=1e-9)
    ab, ba = space.geodesic(V, B), space.geodesic(B, V)
    assert ab.converged and ba.converged
    assert ab.path.shape == (5, len(V), 3)
    np.testing.assert_array_equal(ab.path[0], V)
    np.testing.assert_array_equal(ab.path[-1], B)
    assert abs(ab.length - ba.length) <= 1e-6 * ab.length
    np.testing.assert_allclose(ab.path[::-1], ba.path, atol=1e-4)
    # The solver improved on the straight start (measured: 9 iterations, energy 0.3 % below it).
    assert ab.energy < ab.initial_energy
    assert len(ab.segment_lengths) == 4 and 1 <= ab.iterations <= 100


def test_defaults_are_the_librarys(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F)
    assert space.metric == "isometric (bending 0.0001, lambda 0.01, l2-areas frozen, scale invariant)"
    assert space.steps == 8
    explicit = qs.ShapeSpace(
        F, metric="isometric", lam=0.01, metric_scale="invariant", stretch=0.1, steps=8, solver="preconditioned"
    )
    assert space.metric == explicit.metric
    assert space.dist(V, B) == explicit.dist(V, B)
    calibrated = qs.ShapeSpace(F, metric_scale="calibrated")
    assert calibrated.metric == "isometric (lambda 0.01, l2-areas frozen, scale calibrated)"
    previous = qs.ShapeSpace(F, metric="quasi-conformal", lam=0.1, metric_scale="raw", qc_weights="raw")
    assert previous.metric == (
        "quasi-conformal (form quadratic, weights endpoints, qc-weights raw, lambda 0.1, l2-areas frozen, scale raw)"
    )
    qc = qs.ShapeSpace(F, metric="quasi-conformal", qc_floor=0.25, qc_smooth=2)
    assert "qc-weights rms, qc-floor 0.25, qc-smooth 2" in qc.metric
    assert "*" not in qc.metric and "*" not in repr(qc)
    with pytest.raises(ValueError, match="metric_scale"):
        qs.ShapeSpace(F, metric_scale="size")
    with pytest.raises(ValueError, match="qc_floor"):
        qs.ShapeSpace(F, qc_floor=-1.0)


def test_stretch_weighs_the_change_of_area(pair, synthetic):
    import pickle

    V, B, F = pair  # B changes the faces' areas (y scaled by 0.8)
    stretched = qs.ShapeSpace(F, metric="conformal", stretch=0.5, steps=2)
    free = qs.ShapeSpace(F, metric="conformal", stretch=0.0, steps=2)
    assert "stretch 0.5," in stretched.metric and "stretch 0," in free.metric
    assert qs.ShapeSpace(F, metric="conformal").metric == qs.ShapeSpace(F, metric="conformal", stretch=0.1).metric
    assert pickle.loads(pickle.dumps(stretched)).metric == stretched.metric
    d_stretched, d_free = stretched.dist(V, B), free.dist(V, B)
    assert d_stretched > d_free > 0.0, (d_stretched, d_free)
    with pytest.raises(ValueError, match="^stretch must be >= 0"):
        qs.ShapeSpace(F, metric="conformal", stretch=-1.0)
    with pytest.raises(ValueError, match="^stretch must be >= 0"):
        qs.similarity_matrix(synthetic, metric="conformal", stretch=-1.0, progress=False)


def test_dist_stops_when_the_length_settles_and_length_tolerance_switches_it_off(pair):
    V, B, F = pair
    for metric in ["isometric", "conformal"]:
        default = qs.ShapeSpace(F, metric=metric, steps=4)
        off = qs.ShapeSpace(F, metric=metric, steps=4, length_tolerance=0)
        # The geodesic is a path solve: its length is the distance solved without the length test.
        assert off.dist(V, B) == off.geodesic(V, B).length
        assert default.geodesic(V, B).length == off.geodesic(V, B).length
        tight = qs.ShapeSpace(F, metric=metric, steps=4, tolerance=1e-10, energy_tolerance=0, length_tolerance=0)
        d, t = default.dist(V, B), tight.dist(V, B)
        assert abs(d - t) <= 1e-7 * t, (metric, d, t)
    with pytest.raises(ValueError, match="length_tolerance"):
        qs.ShapeSpace(F, length_tolerance=-1.0)


def test_log_is_the_first_step_of_the_geodesic_and_norms_agree(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="isometric", steps=4, reference=V)
    g = space.geodesic(V, B)
    log, d = space.log(V, B)
    assert log.shape == V.shape
    assert d == pytest.approx(g.length, rel=1e-9)
    np.testing.assert_allclose(V + log / 4, g.path[1], atol=1e-9)
    X = B - V
    # The squared norm charges the bending term's change of the dihedral angles from V to B, the
    # inner product its linearization at V: equal to second order; exactly without the term.
    assert space.squared_norm(V, X) == pytest.approx(space.inner(V, X, X, ends=(V, B)), rel=1e-3)
    flat = qs.ShapeSpace(F, metric="isometric", steps=4, reference=V, bending=0.0)
    assert flat.squared_norm(V, X) == pytest.approx(flat.inner(V, X, X, ends=(V, B)), rel=1e-8)
    assert space.inner(V, X, 2 * X) == pytest.approx(2 * space.inner(V, X, X), rel=1e-10)


def test_transfer_to_its_own_base_is_itself_and_transport_keeps_shapes(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="quasi-conformal", steps=3, reference=V)
    poses = np.stack([V, B])
    for method in ["parallel", "euclidean"]:
        np.testing.assert_allclose(space.transfer(poses, V, method=method), poses, atol=1e-9)
    moved = space.transfer(poses, 1.1 * V)
    # The default is the CLI's (Euclidean transfer).
    np.testing.assert_array_equal(moved, space.transfer(poses, 1.1 * V, method="euclidean"))
    assert moved.shape == poses.shape
    np.testing.assert_array_equal(moved[0], 1.1 * V)
    g = space.geodesic(V, B)
    w = space.transport(g.path, B - V)
    assert w.shape == V.shape and np.all(np.isfinite(w))
    np.testing.assert_array_equal(space.transport(g.path, B - V, method="euclidean"), B - V)


def test_interpolation_keeps_key_poses_and_pairwise_is_a_distance_matrix(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="isometric", steps=2, reference=V)
    dense = space.interpolate(np.stack([V, B]), insert=3, levels=1)
    assert dense.shape == (5, len(V), 3)
    np.testing.assert_array_equal(dense[0], V)
    np.testing.assert_array_equal(dense[-1], B)
    D = space.pairwise_distances(dense, progress=False)
    assert D.shape == (5, 5)
    np.testing.assert_array_equal(D, D.T)
    np.testing.assert_array_equal(np.diag(D), 0.0)
    assert D[0, 4] == space.dist(V, B)
    # The interpolated poses lie on the way: the path through them is not much longer.
    assert sum(D[i, i + 1] for i in range(4)) < 1.05 * D[0, 4]
    mean = space.karcher_mean(np.stack([V, B]))
    assert space.dist(mean, V) == pytest.approx(space.dist(mean, B), rel=0.1)


def test_bad_arguments_raise_value_errors_naming_them(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, steps=2)
    with pytest.raises(ValueError, match=r"^b: expected an array of shape \(42, 3\)"):
        space.dist(V, B[:10])
    with pytest.raises(ValueError, match="^a: cannot be read"):
        space.dist("not an array", B)
    bad = V.copy()
    bad[5, 1] = np.nan
    with pytest.raises(ValueError, match="^a: vertex 5"):
        space.dist(bad, B)
    with pytest.raises(ValueError, match="^metric"):
        qs.ShapeSpace(F, metric="bogus")
    with pytest.raises(ValueError, match="^lam"):
        qs.ShapeSpace(F, lam=-1.0)
    with pytest.raises(ValueError, match="^steps"):
        qs.ShapeSpace(F, steps=0)
    with pytest.raises(ValueError, match="^solver"):
        qs.ShapeSpace(F, solver="newtonish")
    # A retired solver (docs/log/solvers.md) names the accepted ones.
    with pytest.raises(ValueError, match="^solver.*retired.*preconditioned, hessian-kronecker or pose-kronecker"):
        qs.ShapeSpace(F, solver="lbfgs")
    with pytest.raises(ValueError, match="^form"):
        qs.ShapeSpace(F, form="cubic")
    with pytest.raises(ValueError, match="^faces"):
        qs.ShapeSpace(F[:, :2])
    with pytest.raises(ValueError, match="^faces"):
        qs.ShapeSpace(-F)
    with pytest.raises(ValueError, match="^poses"):
        space.interpolate(V)
    with pytest.raises(ValueError, match="^threads"):
        space.pairwise_distances(np.stack([V, B]), threads=0)
    with pytest.raises(ValueError, match="^transport"):
        space.transfer(np.stack([V, B]), V, method="teleport")


def test_two_python_threads_at_once_get_the_sequential_results(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, metric="conformal", steps=4, reference=V)
    targets = [B, 0.5 * (V + B), V + 0.1 * (B - V) ** 2, 1.2 * B]
    expected = [space.dist(V, t) for t in targets]
    with ThreadPoolExecutor(max_workers=2) as pool:
        got = list(pool.map(lambda t: space.dist(V, t), targets * 2))
    assert got == expected * 2


def test_help_documents_every_method():
    for name, member in inspect.getmembers(qs.ShapeSpace):
        if not name.startswith("_"):
            assert member.__doc__ and len(member.__doc__) > 20, name
    for f in [qs.read_mesh, qs.write_mesh, qs.similarity_matrix, qs.mds, qs.scores, qs.Dataset, qs.KMeans]:
        assert f.__doc__ and len(f.__doc__) > 40, f
