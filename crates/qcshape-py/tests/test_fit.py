"""qs.fit (issue 49): a template fitted to a surface of another triangulation, a point cloud and
mesh objects; bad input is a ValueError with one clear message."""

import numpy as np
import pytest

import qcshape as qs


def target(level=3, scale=1.0):
    """A level-3 sphere (642 vertices) stretched and dented: another triangulation than the
    42-vertex template."""
    V, F = qs.icosphere(level)
    W = np.column_stack([1.3 * V[:, 0], 0.9 * V[:, 1], V[:, 2] + 0.2 * V[:, 0] ** 2]) * scale
    return W, F


def test_fits_another_triangulation_and_reports_quality(sphere):
    V, F = sphere
    W, G = target()
    fitted, residual, quality = qs.fit(V, F, W, G)
    assert fitted.shape == V.shape and fitted.dtype == np.float64
    assert residual.shape == (len(V),)
    assert quality["mean"] < 0.1 and quality["flipped"] == 0 and quality["poor"] is False
    # The residual is the distance to the target, in its units: small against an edge.
    assert residual.max() < 0.2 * quality["edge_length"]
    # Scale: the same fit at 100 times the size, the same relative quality.
    big, _, q100 = qs.fit(V, F, 100.0 * W, G)
    assert abs(q100["mean"] - quality["mean"]) < 1e-3
    assert abs(q100["scale"] / quality["scale"] - 100.0) < 1e-6 * 100.0


def test_point_clouds_and_determinism(sphere):
    V, F = sphere
    W, _ = target()
    a, r, q = qs.fit(V, F, W)
    b, _, _ = qs.fit(V, F, W)
    assert np.array_equal(a, b)
    assert q["flipped"] == 0 and q["median_vertex"] < 0.3


def test_a_global_warp_follows_a_taper():
    # An ellipsoid onto its taper (a quadratic map of space) on a finer mesh, placed as given:
    # the degree-2 warp recovers where each vertex went better than the stages alone.
    def ellipsoid(level, turn):
        V, F = qs.icosphere(level)
        c, s = np.cos(turn), np.sin(turn)
        V = np.column_stack([c * V[:, 0] - s * V[:, 1], s * V[:, 0] + c * V[:, 1], V[:, 2]])
        return V * [1.2, 0.9, 0.8], F

    def taper(P):
        return np.column_stack([P[:, :2] * (1.0 + 0.4 * P[:, 2:3]), P[:, 2]])

    V, F = ellipsoid(2, 0.0)
    W, G = ellipsoid(4, 0.3)
    truth = taper(V)
    edge = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    errors = []
    for degree in (0, 2):
        X, _, q = qs.fit(V, F, taper(W), G, prior="affine", alignment="none", global_degree=degree)
        assert q["mean"] < 0.1
        errors.append(np.median(np.linalg.norm(X - truth, axis=1)) / edge)
    assert errors[1] < 0.5 * errors[0], errors


def test_mesh_objects():
    trimesh = pytest.importorskip("trimesh")
    V, F = qs.icosphere(1)
    W, G = target()
    tm = trimesh.Trimesh(V, F, process=False)
    scan = trimesh.Trimesh(W, G, process=False)
    fitted, _, q = qs.fit(tm, tm, scan)
    ref, _, _ = qs.fit(V, F, W, G)
    assert np.allclose(fitted, ref)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda V, F, W, G: qs.fit(V, F, np.zeros((0, 3)), None), "empty"),
        (lambda V, F, W, G: qs.fit(V, F, np.where(np.arange(len(W))[:, None] == 5, np.nan, W), G), "non-finite"),
        (lambda V, F, W, G: qs.fit(V, F, W, G + 10_000), "target face"),
        (lambda V, F, W, G: qs.fit(V, F, W + 100.0, G, alignment="none"), "no overlap"),
        (lambda V, F, W, G: qs.fit(V, F, W, G, alignment="affine"), "alignment"),
        (lambda V, F, W, G: qs.fit(V, F, W, G, stages=0), "stages"),
        (lambda V, F, W, G: qs.fit(V, F, W, G, global_degree=6), "global_degree"),
        (lambda V, F, W, G: qs.fit(V[:, :2], F, W, G), "template_vertices"),
    ],
)
def test_bad_input_is_a_value_error(sphere, call, message):
    V, F = sphere
    W, G = target()
    with pytest.raises(ValueError, match=message) as e:
        call(V, F, W, G)
    assert "\n" not in str(e.value)
