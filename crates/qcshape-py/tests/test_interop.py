"""Files qcshape writes are read by meshio and pyvista with their named point arrays.

meshio reads legacy .vtk (qcshape writes an UNSTRUCTURED_GRID of triangles); it has no .vtp
reader, so .vtp is checked with pyvista when installed and always with the standard library
(xml.etree, base64, struct). scripts/test must `pip install meshio` (and optionally pyvista)
for the meshio tests to run; they are skipped otherwise.
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
