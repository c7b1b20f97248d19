"""Mesh objects checked against the space's connectivity (issue 60, item 1): a trimesh, pyvista
or meshio pose whose faces are not the space's is refused with the CLI's message ("shapes do not
share one connectivity: face 0 is ... in one and ... in the other"), or, when its faces are the
space's face for face after renumbering its vertices (a mesh whose vertices were reordered, its
faces kept in order), renumbered with a QcshapeWarning that says so. Before, its vertices were
used in their own order and gave a wrong distance without a word (0.958 for a true 0.205)."""

import importlib.util
import warnings

import numpy as np
import pytest

import qcshape as qs

LIBS = [lib for lib in ("trimesh", "pyvista", "meshio") if importlib.util.find_spec(lib) is not None]


def make(lib, V, F):
    if lib == "trimesh":
        import trimesh

        return trimesh.Trimesh(V, F, process=False)
    if lib == "pyvista":
        import pyvista

        return pyvista.PolyData(V, np.hstack([np.full((len(F), 1), 3), F]).ravel())
    import meshio

    return meshio.Mesh(V, [("triangle", F)])


def renumbered(V, F, seed=0):
    """The issue's renumbered pose: vertices permuted, faces renumbered, face order kept."""
    p = np.random.default_rng(seed).permutation(len(V))
    return V[p], np.argsort(p)[F]


def caught(call):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = call()
    return out, [str(x.message) for x in w if issubclass(x.category, qs.QcshapeWarning)]


@pytest.fixture(params=LIBS)
def lib(request):
    return request.param


def test_a_renumbered_pose_is_renumbered_with_a_warning(lib, pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F)
    truth = space.dist(VA, VB)
    Vp, Fp = renumbered(VB, F)
    a, b = make(lib, VA, F), make(lib, Vp, Fp)
    d, msgs = caught(lambda: space.dist(a, b))
    assert d == truth, (d, truth)
    assert len(msgs) == 1 and "b: the " in msgs[0] and "numbered differently" in msgs[0]
    assert "renumbered" in msgs[0]
    g, msgs = caught(lambda: space.geodesic(b, a))
    assert any("numbered differently" in m for m in msgs)
    np.testing.assert_array_equal(g.path[0], VB)
    np.testing.assert_array_equal(g.path[-1], VA)
    # A pose sequence of mesh objects, and a Dataset of them (faces from the first mesh).
    dense, msgs = caught(lambda: space.interpolate([a, b], insert=1))
    assert any("poses[1]" in m for m in msgs)
    np.testing.assert_array_equal(dense[-1], VB)
    ds, msgs = caught(lambda: qs.Dataset([[a, b], [a, a]]))
    assert any("poses[0][1]" in m for m in msgs)
    np.testing.assert_array_equal(ds[0][1], VB)


def test_a_pose_of_another_connectivity_is_refused_with_the_cli_message(lib, pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F)
    Vp, Fp = renumbered(VB, F)
    # Faces reordered too: no renumbering follows from the face order.
    order = np.random.default_rng(1).permutation(len(F))
    b = make(lib, Vp, Fp[order])
    a = make(lib, VA, F)
    pattern = r"b: shapes do not share one connectivity: face \d+ is \[\d+, \d+, \d+\] in one and \[\d+, \d+, \d+\] in the other"
    with pytest.raises(ValueError, match=pattern):
        space.dist(a, b)
    with pytest.raises(ValueError, match=pattern):
        space.geodesic(a, b)
    with pytest.raises(ValueError, match=r"poses\[0\]\[1\]: shapes do not share one connectivity"):
        qs.Dataset([[a, b]], faces=F)
    with pytest.raises(ValueError, match=r"poses\[0\]\[1\]: shapes do not share one connectivity"):
        qs.Dataset([[a, b]])
    # Another triangulation altogether (fewer faces).
    with pytest.raises(ValueError, match=r"b: shapes do not share one connectivity: 80 faces against 79"):
        space.dist(VA, make(lib, VB, F[:-1]))


def test_a_pose_with_the_space_faces_passes_unchanged_and_silently(lib, pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F)
    d, msgs = caught(lambda: space.dist(make(lib, VA, F), make(lib, VB, F)))
    assert d == space.dist(VA, VB) and msgs == []


def test_the_issue_example_gives_the_true_distance():
    trimesh = pytest.importorskip("trimesh")
    VA, F = qs.icosphere(1)
    VB = VA * np.array([1.0, 1.2, 0.9]) + 0.1 * VA[:, [1, 2, 0]] ** 2
    p = np.random.default_rng(0).permutation(42)
    tp = trimesh.Trimesh(VB[p], np.argsort(p)[F], process=False)
    space = qs.ShapeSpace(F)
    d, msgs = caught(lambda: space.dist(trimesh.Trimesh(VA, F, process=False), tp))
    assert d == space.dist(VA, VB) and len(msgs) == 1


def test_arrays_without_faces_are_not_compared(pair):
    VA, VB, F = pair
    with pytest.raises(ValueError, match="faces: required when the poses are arrays"):
        qs.Dataset([[VA, VB]])


def test_unused_vertex_hint(pair):
    VA, VB, F = pair
    # The last vertex in no face: the space infers 41 vertices from the faces.
    keep = ~np.any(F == 41, axis=1)
    with pytest.raises(ValueError, match=r"vertices 41\.\.41 of a are in no face: give ShapeSpace\(F, n_vertices=42\)"):
        qs.ShapeSpace(F[keep]).dist(VA, VB)
