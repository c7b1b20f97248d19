"""Issue 60, items 5 and 6 in the Python package: what used to happen without a word now
warns or says why (a poor qs.fit, poses of very different sizes, a mesh file given to
Dataset.load)."""

import warnings

import numpy as np
import pytest

import qcshape as qs


def caught(call):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = call()
    return out, [str(x.message) for x in w if issubclass(x.category, qs.QcshapeWarning)]


def test_a_poor_fit_warns_as_the_cli_does():
    V, F = qs.icosphere(2)
    T, TF = qs.icosphere(3)
    # A long, thin wavy cigar: the sphere cannot follow it (mean distance 0.63 edge lengths;
    # at 0.3 thick the area-scaled alignment fits it to 0.16, under the 0.2 limit).
    T = T * np.array([4.0, 0.15, 0.15])
    T[:, 0] += 0.8 * np.sin(15.0 * qs.icosphere(3)[0][:, 1])
    (_, _, quality), msgs = caught(lambda: qs.fit(V, F, T, TF))
    assert quality["poor"] is True
    assert len(msgs) == 1 and msgs[0].startswith("poor fit of the template to the target: mean distance")


def test_a_good_fit_is_silent():
    V, F = qs.icosphere(2)
    T, TF = qs.icosphere(3)
    (_, _, quality), msgs = caught(lambda: qs.fit(V, F, 1.1 * T, TF))
    assert quality["poor"] is False and msgs == []


def test_poses_of_very_different_sizes_warn_naming_the_units(pair):
    VA, VB, F = pair
    space = qs.ShapeSpace(F)
    _, msgs = caught(lambda: space.dist(VA, 1000.0 * VA, steps=2))
    size = [m for m in msgs if "mean edge length" in m]
    assert len(size) == 1 and "differ by a factor of 1000" in size[0] and "same units" in size[0]
    assert "mean-edge units" in size[0]
    _, msgs = caught(lambda: space.geodesic(VA, 2.0 * VB, steps=2))
    assert not any("mean edge length" in m for m in msgs)


def test_dataset_load_of_a_mesh_file_says_it_is_a_mesh_file(tmp_path, sphere):
    V, F = sphere
    path = tmp_path / "x.vtp"
    qs.write_mesh(str(path), V, F)
    with pytest.raises(ValueError, match=r"x\.vtp: is a mesh file, not a data set"):
        qs.Dataset.load(str(path))


def test_a_semicolon_manifest_names_the_separator(tmp_path, sphere):
    V, F = sphere
    qs.write_mesh(str(tmp_path / "a.ply"), V, F)
    m = tmp_path / "m.csv"
    m.write_text("deformation;label;pose;path\nw;x;0;a.ply\nw;x;1;a.ply\n")
    with pytest.raises(ValueError, match="separator is a comma, not ';'"):
        qs.Dataset.load(str(m))


def test_geodesic_flags_an_unconverged_distance(pair):
    VA, VB, F = pair
    g, msgs = caught(lambda: qs.ShapeSpace(F, metric="conformal").geodesic(VA, VB, steps=2))
    assert g.converged is True and not any("iteration limit" in m for m in msgs)


def test_a_quad_file_is_triangulated_with_a_warning(tmp_path):
    # Issue 60: quad files were triangulated silently while quad mesh objects are refused.
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nf 1 4 3 2\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n")
    (V, F), msgs = caught(lambda: qs.read_mesh(str(obj)))
    assert F.shape == (6, 3)
    assert len(msgs) == 1 and "quad.obj: fan-triangulated 1 polygon(s)" in msgs[0]
