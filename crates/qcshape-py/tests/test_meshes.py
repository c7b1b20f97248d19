"""Mesh objects in and out (issue 50, item 1): trimesh, pyvista (flat faces) and meshio objects
wherever positions or faces are taken, with the same numbers as plain arrays; qs.to_trimesh /
to_pyvista / to_meshio; none of these libraries imported unless their objects are used.
scripts/test installs the three; each test is skipped when its library is missing."""

import subprocess
import sys

import numpy as np
import pytest

import qcshape as qs


def _make(kind, V, F):
    return {"trimesh": qs.to_trimesh, "pyvista": qs.to_pyvista, "meshio": qs.to_meshio}[kind](V, F)


KINDS = ["trimesh", "pyvista", "meshio"]


@pytest.mark.parametrize("kind", KINDS)
def test_readme_calls_with_mesh_objects_equal_the_arrays(kind, pair, tmp_path):
    pytest.importorskip(kind)
    VA, VB, F = pair
    ma, mb = _make(kind, VA, F), _make(kind, VB, F)
    space, mspace = qs.ShapeSpace(F), qs.ShapeSpace(ma)
    assert mspace.n_vertices == len(VA)
    np.testing.assert_array_equal(mspace.faces, F)
    g, mg = space.geodesic(VA, VB, steps=4), mspace.geodesic(ma, mb, steps=4)
    np.testing.assert_array_equal(mg.path, g.path)
    assert mg.length == g.length
    assert mspace.dist(ma, mb) == space.dist(VA, VB)
    np.testing.assert_array_equal(mspace.interpolate([ma, mb], insert=1), space.interpolate(np.stack([VA, VB]), insert=1))
    np.testing.assert_array_equal(
        mspace.transfer([ma, mb], _make(kind, 1.1 * VA, F)), space.transfer(np.stack([VA, VB]), 1.1 * VA)
    )
    log, d = mspace.log(ma, mb, steps=2)
    np.testing.assert_array_equal(log, space.log(VA, VB, steps=2)[0])
    assert qs.ShapeSpace(F, reference=ma).dist(VA, VB) == qs.ShapeSpace(F, reference=VA).dist(VA, VB)
    # write_mesh(path, mesh) and a Dataset of mesh objects.
    qs.write_mesh(tmp_path / "m.ply", mb)
    V2, F2 = qs.read_mesh(tmp_path / "m.ply")
    np.testing.assert_array_equal(V2, VB)
    np.testing.assert_array_equal(F2, F)
    ds = qs.Dataset([[ma, mb], [mb, ma]], faces=ma)
    np.testing.assert_array_equal(ds[0], np.stack([VA, VB]))


@pytest.mark.parametrize("kind", KINDS)
def test_as_arrays_round_trips_the_to_functions(kind, sphere):
    pytest.importorskip(kind)
    V, F = sphere
    V2, F2 = qs.as_arrays(_make(kind, V, F))
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    assert V2.dtype == np.float64 and F2.dtype == np.int64
    # Poses (K, nV, 3), e.g. a geodesic's path: one object per pose.
    many = _make(kind, np.stack([V, 2 * V]), F)
    assert len(many) == 2
    np.testing.assert_array_equal(qs.as_arrays(many[1])[0], 2 * V)


def test_pyvista_flat_face_array_is_read_as_triangles(sphere):
    V, F = sphere
    flat = np.hstack([np.full((len(F), 1), 3), F]).ravel()
    assert qs.ShapeSpace(flat).dist(V, 1.2 * V) == qs.ShapeSpace(F).dist(V, 1.2 * V)


def test_pyvista_non_triangle_face_is_refused_naming_it():
    pv = pytest.importorskip("pyvista")
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, -1, 0]], dtype=float)
    mesh = pv.PolyData(V, np.array([3, 1, 0, 4, 4, 0, 1, 2, 3]))
    with pytest.raises(ValueError, match=r"face 1 has 4 corners.*triangulate"):
        qs.ShapeSpace(mesh)
    # pyvista's own triangulation is accepted.
    assert qs.ShapeSpace(mesh.triangulate()).faces.shape == (3, 3)
    flat = np.array([3, 1, 0, 4, 4, 0, 1, 2, 3])
    with pytest.raises(ValueError, match="face 1 has 4 corners"):
        qs.ShapeSpace(flat)


def test_meshio_quads_are_refused_and_other_cells_ignored(sphere):
    meshio = pytest.importorskip("meshio")
    V, F = sphere
    with pytest.raises(ValueError, match="'quad' cells"):
        qs.ShapeSpace(meshio.Mesh(V, [("triangle", F), ("quad", np.array([[0, 1, 2, 3]]))]))
    with_lines = meshio.Mesh(V, [("line", np.array([[0, 1]])), ("triangle", F)])
    np.testing.assert_array_equal(qs.ShapeSpace(with_lines).faces, F)
    with pytest.raises(ValueError, match="no 'triangle' cells"):
        qs.ShapeSpace(meshio.Mesh(V, [("line", np.array([[0, 1]]))]))


def test_write_mesh_without_faces_needs_a_mesh_object(tmp_path, sphere):
    V, _ = sphere
    with pytest.raises(ValueError, match="faces: missing"):
        qs.write_mesh(tmp_path / "m.ply", V)


def test_no_mesh_library_is_imported_for_arrays(tmp_path):
    code = (
        "import sys, numpy as np, qcshape as qs\n"
        "V, F = qs.icosphere(1)\n"
        "s = qs.ShapeSpace(F)\n"
        "s.dist(V, 1.1 * V); s.interpolate([V, 1.1 * V], insert=1)\n"
        f"qs.write_mesh({str(tmp_path / 'a.ply')!r}, V, F)\n"
        "print(sorted(m for m in ('trimesh', 'pyvista', 'meshio', 'vtk') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
