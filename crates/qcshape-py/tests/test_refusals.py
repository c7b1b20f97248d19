"""Issue 40's Python refusals: option values out of their bounds, vertex counts and face
indices that would allocate without limit, and zero shapes all raise ValueError naming the
argument; nothing aborts the interpreter."""

import numpy as np
import pytest

import qcshape as qs


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda V, F: qs.ShapeSpace(F, steps=-1), "steps"),
        (lambda V, F: qs.ShapeSpace(F, steps=10**30), "steps"),
        (lambda V, F: qs.ShapeSpace(F, steps=18446744073709551615), "steps"),
        (lambda V, F: qs.ShapeSpace(F, qc_smooth=-1), "qc_smooth"),
        (lambda V, F: qs.ShapeSpace(F, n_vertices=10**10), "n_vertices"),
        (lambda V, F: qs.ShapeSpace(F, n_vertices=-5), "n_vertices"),
        (lambda V, F: qs.ShapeSpace(F).dist(V, V, steps=-1), "steps"),
        (lambda V, F: qs.ShapeSpace(F).geodesic(V, V, steps=100_000), "steps"),
        (lambda V, F: qs.ShapeSpace(F).interpolate(np.stack([V, V]), insert=-1), "insert"),
        (lambda V, F: qs.ShapeSpace(F).interpolate(np.stack([V, V]), insert=2**64 - 1), "insert"),
        (lambda V, F: qs.ShapeSpace(F).interpolate(np.stack([V, V]), levels=-1), "levels"),
        (lambda V, F: qs.icosphere(level=-1), "level"),
        (lambda V, F: qs.icosphere(level=99), "level"),
        (lambda V, F: qs.Dataset.synthetic(level=-1), "level"),
    ],
)
def test_bad_integer_arguments_raise_value_errors_naming_them(sphere, call, name):
    V, F = sphere
    with pytest.raises(ValueError, match=name):
        call(V, F)


def test_face_index_beyond_the_vertex_limit_is_refused(sphere):
    _, F = sphere
    G = np.array(F, dtype=np.int64)
    G[0, 0] = 3_000_000_000
    with pytest.raises(ValueError, match="faces"):
        qs.ShapeSpace(G)


def test_write_mesh_refuses_a_folder(sphere, tmp_path):
    V, F = sphere
    with pytest.raises(ValueError, match="is a folder"):
        qs.write_mesh(tmp_path, V, F)


def test_a_zero_reference_is_a_value_error(sphere):
    V, F = sphere
    with pytest.raises(ValueError):
        qs.ShapeSpace(F, reference=np.zeros_like(V))


def test_arrays_get_the_mesh_readers_checks(pair):
    V, B, F = pair
    space = qs.ShapeSpace(F, steps=2)
    with pytest.raises(ValueError, match="second shape: .*degenerate"):
        space.geodesic(V, np.zeros_like(V))
    with pytest.raises(ValueError, match="first shape: .*degenerate"):
        space.dist(np.zeros_like(V), B)
    # A zero tangent vector is still a vector.
    assert space.squared_norm(V, np.zeros_like(V)) == 0.0
    with pytest.raises(ValueError, match=r"poses\[1\], pose 1: .*degenerate"):
        qs.Dataset(poses=[np.stack([V, B]), np.stack([V, np.zeros_like(V)])], faces=F)


def test_duplicate_deformation_names_are_refused(pair):
    V, B, F = pair
    with pytest.raises(ValueError, match='names: "a" names deformations 0 and 2'):
        qs.Dataset(poses=[np.stack([V, B])] * 3, faces=F, names=["a", "b", "a"])
