"""Interop both ways, with named point arrays.

Files qcshape writes are read by meshio and pyvista (meshio reads legacy .vtk, qcshape writes an
UNSTRUCTURED_GRID of triangles; it has no .vtp reader, so .vtp is checked with pyvista when
installed and always with the standard library: xml.etree, base64, struct). Files meshio,
pyvista/VTK (after compute_normals, with the METADATA blocks VTK adds once it has computed
an array's range) and trimesh write are read back by `qs.read_mesh(path, point_data=True)`.
scripts/test installs meshio, pyvista and trimesh; each test is skipped when its tool is
missing. pyvista is only used to write files (no rendering), so the tests run headless.
"""

import base64
import struct
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import qcshape as qs


def fields(V):
    height = V[:, 2] + 0.5
    disp = np.column_stack([0.1 * V[:, 0], 0.2 * V[:, 1], 0.3 * V[:, 2]])
    return height, disp


def test_meshio_reads_named_arrays_of_a_qcshape_vtk(tmp_path, sphere):
    meshio = pytest.importorskip("meshio")
    V, F = sphere
    height, disp = fields(V)
    path = tmp_path / "m.vtk"
    qs.write_mesh(path, V, F, point_data={"height": height, "disp": disp})
    m = meshio.read(path)
    np.testing.assert_array_equal(m.points, V)
    assert m.cells[0].type == "triangle"
    np.testing.assert_array_equal(m.cells[0].data, F)
    # meshio returns SCALARS as (nV, 1).
    np.testing.assert_array_equal(np.ravel(m.point_data["height"]), height)
    np.testing.assert_array_equal(m.point_data["disp"], disp)


def test_pyvista_reads_named_arrays_of_a_qcshape_vtp(tmp_path, sphere):
    pv = pytest.importorskip("pyvista")
    V, F = sphere
    height, disp = fields(V)
    path = tmp_path / "m.vtp"
    qs.write_mesh(path, V, F, point_data={"height": height, "disp": disp})
    m = pv.read(path)
    np.testing.assert_array_equal(m.points, V)
    np.testing.assert_array_equal(m.point_data["height"], height)
    np.testing.assert_array_equal(m.point_data["disp"], disp)


def test_qcshape_vtp_is_plain_vtk_xml(tmp_path, sphere):
    V, F = sphere
    height, disp = fields(V)
    path = tmp_path / "m.vtp"
    qs.write_mesh(path, V, F, point_data={"height": height, "disp": disp})
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64"

    def array(el):
        raw = base64.b64decode(el.text.strip())
        (n,) = struct.unpack("<Q", raw[:8])
        return np.frombuffer(raw[8 : 8 + n], dtype="<f8" if el.get("type") == "Float64" else "<i8")

    arrays = {el.get("Name"): el for el in root.iter("DataArray")}
    np.testing.assert_array_equal(array(arrays["height"]), height)
    np.testing.assert_array_equal(array(arrays["disp"]).reshape(-1, 3), disp)
    np.testing.assert_array_equal(array(arrays["Points"]).reshape(-1, 3), V)
    np.testing.assert_array_equal(array(arrays["connectivity"]).reshape(-1, 3), F)
    # qcshape reads its own file back.
    V2, F2 = qs.read_mesh(path)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)


# --- files other tools write, read by qcshape -------------------------------------------------


def same_triangles(F, G):
    """The same set of triangles up to the order of faces and a rotation of their corners."""

    def canon(F):
        F = np.asarray(F)
        k = np.argmin(F, axis=1)
        rolled = np.array([np.roll(f, -i) for f, i in zip(F, k)])
        return sorted(map(tuple, rolled))

    return canon(F) == canon(G)


@pytest.mark.parametrize(
    "name, kwargs, atol",
    [
        ("m.vtu", {}, 0),  # meshio's default: inline base64, zlib
        ("m_raw.vtu", {"compression": None}, 0),
        ("m_ascii.vtu", {"binary": False}, 1e-9),  # meshio prints 12 significant digits
        ("m.vtk", {}, 0),  # legacy VTK 5.1, binary
        ("m_ascii.vtk", {"binary": False}, 1e-9),
        ("m.ply", {}, 0),
    ],
)
def test_qcshape_reads_meshio_files_with_point_fields(tmp_path, sphere, name, kwargs, atol):
    meshio = pytest.importorskip("meshio")
    V, F = sphere
    height, disp = fields(V)
    path = tmp_path / name
    mesh = meshio.Mesh(V, [("triangle", F)], point_data={"height": height, "disp": disp})
    meshio.write(path, mesh, **kwargs)
    V2, F2, pd = qs.read_mesh(path, point_data=True)
    np.testing.assert_allclose(V2, V, rtol=0, atol=atol)
    np.testing.assert_array_equal(F2, F)
    np.testing.assert_allclose(pd["height"], height, rtol=0, atol=atol)
    if name.endswith(".ply"):
        # meshio's PLY keeps only one-component point data.
        return
    assert pd["disp"].shape == (len(V), 3)
    np.testing.assert_allclose(pd["disp"], disp, rtol=0, atol=atol)


def pyvista_mesh(pv, V, F):
    """The sphere with a `height` field, after compute_normals (adds `Normals`), with its
    points' and arrays' L2-norm ranges computed, as rendering or an XML writer does, so that
    the legacy writer adds METADATA blocks."""
    m = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
    m.point_data["height"] = V[:, 2] + 0.5
    m = m.compute_normals()
    m.GetPoints().GetData().GetRange(-1)
    m.GetPointData().GetArray("Normals").GetRange(-1)
    return m


@pytest.mark.parametrize("name, binary", [("p.vtk", True), ("p_ascii.vtk", False), ("p.vtp", True), ("p_ascii.vtp", False)])
def test_qcshape_reads_pyvista_polydata_with_metadata_and_normals(tmp_path, sphere, name, binary):
    pv = pytest.importorskip("pyvista")
    V, F = sphere
    m = pyvista_mesh(pv, V, F)
    path = tmp_path / name
    m.save(path, binary=binary)
    if name.endswith(".vtk"):
        assert b"METADATA" in path.read_bytes(), "the fixture should hold a METADATA block"
    V2, F2, pd = qs.read_mesh(path, point_data=True)
    # VTK's ASCII writers print floats with 6 (legacy) to 8 (XML) significant digits.
    atol = 0 if binary else 1e-6
    np.testing.assert_allclose(V2, m.points, rtol=0, atol=atol)
    assert len(F2) == len(F), "faces after METADATA are read"
    assert same_triangles(F2, m.faces.reshape(-1, 4)[:, 1:])
    np.testing.assert_allclose(pd["height"], m.point_data["height"], rtol=0, atol=atol)
    assert pd["Normals"].shape == (len(V), 3)
    np.testing.assert_allclose(pd["Normals"], m.point_data["Normals"], rtol=0, atol=atol)


@pytest.mark.parametrize("binary", [True, False])
def test_qcshape_reads_pyvista_unstructured_grid(tmp_path, sphere, binary):
    pv = pytest.importorskip("pyvista")
    V, F = sphere
    grid = pyvista_mesh(pv, V, F).cast_to_unstructured_grid()
    path = tmp_path / "g.vtu"
    grid.save(path, binary=binary)
    V2, F2, pd = qs.read_mesh(path, point_data=True)
    atol = 0 if binary else 1e-6  # VTK's ASCII digits, as above
    np.testing.assert_allclose(V2, grid.points, rtol=0, atol=atol)
    assert same_triangles(F2, F)
    np.testing.assert_allclose(pd["Normals"], grid.point_data["Normals"], rtol=0, atol=atol)
    np.testing.assert_allclose(pd["height"], grid.point_data["height"], rtol=0, atol=atol)
    # And the legacy UNSTRUCTURED_GRID of the same data.
    grid.save(tmp_path / "g.vtk", binary=binary)
    V3, F3, pd3 = qs.read_mesh(tmp_path / "g.vtk", point_data=True)
    np.testing.assert_allclose(V3, V2, rtol=0, atol=atol)
    np.testing.assert_array_equal(F3, F2)
    np.testing.assert_allclose(pd3["height"], pd["height"], rtol=0, atol=atol)


def test_qcshape_refuses_volume_cells_of_a_vtu(tmp_path):
    pv = pytest.importorskip("pyvista")
    path = tmp_path / "tet.vtu"
    pv.Sphere().delaunay_3d().save(path)
    with pytest.raises(ValueError, match="tetrahedron"):
        qs.read_mesh(path)


@pytest.mark.parametrize("name, kwargs", [("t.ply", {}), ("t_ascii.ply", {"encoding": "ascii"}), ("t.obj", {}), ("t.stl", {}), ("t.off", {})])
def test_qcshape_reads_trimesh_files_with_vertex_attributes(tmp_path, sphere, name, kwargs):
    trimesh = pytest.importorskip("trimesh")
    V, F = sphere
    height, _ = fields(V)
    t = trimesh.Trimesh(V, F, process=False)
    t.vertex_attributes["quality"] = height
    path = tmp_path / name
    t.export(path, **kwargs)
    V2, F2, pd = qs.read_mesh(path, point_data=True)
    assert len(F2) == len(F)
    if name.endswith(".stl"):
        # STL stores float32 corners; qcshape welds them back into vertices (in the order
        # they first appear).
        assert len(V2) == len(V)
        np.testing.assert_allclose(np.array(sorted(map(tuple, V2))), np.array(sorted(map(tuple, V))), atol=1e-6)
        assert pd == {}
        return
    np.testing.assert_allclose(V2, V, atol=1e-6)  # trimesh's text formats print 8 decimals
    np.testing.assert_array_equal(F2, F)
    if name.endswith(".ply"):
        np.testing.assert_allclose(pd["quality"], height, rtol=0, atol=1e-8)
    else:
        assert pd == {}


def test_read_mesh_returns_two_arrays_without_point_data(tmp_path, sphere):
    V, F = sphere
    path = tmp_path / "m.vtu"
    height, disp = fields(V)
    qs.write_mesh(path, V, F, point_data={"height": height, "disp": disp})
    out = qs.read_mesh(path)
    assert len(out) == 2
    V2, F2, pd = qs.read_mesh(path, point_data=True)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    assert list(pd) == ["height", "disp"]
    assert pd["height"].shape == (len(V),) and pd["disp"].shape == (len(V), 3)


@pytest.mark.parametrize(
    "name, text",
    [
        ("points.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n"),
        ("cloud.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n"),
    ],
)
def test_read_mesh_refuses_a_mesh_without_faces(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ValueError, match=f"{name}.*no faces"):
        qs.read_mesh(path)


def test_read_mesh_docstring_names_every_format():
    for ext in [".obj", ".ply", ".off", ".stl", ".vtk", ".vtp", ".vtu"]:
        assert ext in qs.read_mesh.__doc__, ext
    assert "point_data" in qs.read_mesh.__doc__
