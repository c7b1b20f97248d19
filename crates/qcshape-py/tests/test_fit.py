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
        (lambda V, F, W, G: qs.fit(V[:, :2], F, W, G), "template_vertices"),
    ],
)
def test_bad_input_is_a_value_error(sphere, call, message):
    V, F = sphere
    W, G = target()
    with pytest.raises(ValueError, match=message) as e:
        call(V, F, W, G)
    assert "\n" not in str(e.value)
