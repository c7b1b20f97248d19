"""Mesh files from and to numpy arrays (trimesh-style V float (nV, 3), F int (nF, 3))."""

import numpy as np
import pytest

import qcshape as qs


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "vtk"])
def test_write_then_read_gives_the_same_arrays(tmp_path, pair, ext):
    _, B, F = pair
    path = tmp_path / f"mesh.{ext}"
    qs.write_mesh(path, B, F)
    V2, F2 = qs.read_mesh(path)
    assert V2.dtype == np.float64 and V2.shape == B.shape
    assert F2.dtype == np.int64 and F2.shape == F.shape
    np.testing.assert_array_equal(V2, B)
    np.testing.assert_array_equal(F2, F)


def test_other_dtypes_and_orders_are_converted(tmp_path, pair):
    _, B, F = pair
    path = tmp_path / "m.ply"
    qs.write_mesh(str(path), np.asfortranarray(B.astype(np.float32)), F.astype(np.int32).tolist())
    V2, F2 = qs.read_mesh(str(path))
    np.testing.assert_array_equal(V2, B.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(F2, F)


def test_point_data_is_written(tmp_path, pair):
    V, _, F = pair
    values = np.linspace(0.0, 1.0, len(V)) ** 2
    path = tmp_path / "m.vtk"
    qs.write_mesh(path, V, F, point_data={"error": values})
    V2, F2 = qs.read_mesh(path)
    np.testing.assert_array_equal(V2, V)
    text = path.read_text().split()
    at = text.index("SCALARS")
    assert text[at + 1] == "error"
    # SCALARS name type 1 / LOOKUP_TABLE default / values
    got = np.array([float(x) for x in text[at + 6 : at + 6 + len(V)]])
    np.testing.assert_allclose(got, values, rtol=1e-15, atol=0)
    ply = tmp_path / "m.ply"
    qs.write_mesh(ply, V, F, point_data={"error": values})
    assert b"property double error" in ply.read_bytes()


def test_bad_point_data_and_formats_raise_value_errors(tmp_path, pair):
    V, _, F = pair
    with pytest.raises(ValueError, match="per-vertex scalars"):
        qs.write_mesh(tmp_path / "m.obj", V, F, point_data={"e": np.zeros(len(V))})
    with pytest.raises(ValueError, match=r"point_data\[\"e\"\]"):
        qs.write_mesh(tmp_path / "m.ply", V, F, point_data={"e": np.zeros(3)})
    with pytest.raises(ValueError, match="unknown mesh format"):
        qs.write_mesh(tmp_path / "m.xyz", V, F)
    with pytest.raises(ValueError, match="vertices"):
        qs.write_mesh(tmp_path / "m.ply", V[:, :2], F)
    with pytest.raises(ValueError, match="faces"):
        qs.write_mesh(tmp_path / "m.ply", V, F + 0.5)


def test_file_errors_keep_the_file_name_and_line(tmp_path):
    with pytest.raises(OSError, match="missing.ply"):
        qs.read_mesh(tmp_path / "missing.ply")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
    with pytest.raises(ValueError, match=r"bad\.obj.*line 4"):
        qs.read_mesh(bad)
    assert not (tmp_path / "never.ply").exists()
