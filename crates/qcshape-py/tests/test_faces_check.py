"""Face indices checked against the vertex array they come with (issue 50, item 5): the message
names the face and the index, and says when the faces look 1-based."""

import numpy as np
import pytest

import qcshape as qs


@pytest.fixture
def bad_faces(sphere):
    V, F = sphere
    F2 = F.copy()
    F2[17, 0] = 50
    return V, F2


def test_inferred_vertex_count_blames_the_face_not_the_positions(bad_faces):
    V, F2 = bad_faces
    with pytest.raises(ValueError, match=r"faces: face 17 has index 50, but a has 42 vertices"):
        qs.ShapeSpace(F2).dist(V, 1.1 * V)
    with pytest.raises(ValueError, match=r"faces: face 17 has index 50, but poses has 42 vertices"):
        qs.ShapeSpace(F2).interpolate(np.stack([V, 1.1 * V]), insert=1)


def test_one_based_faces_get_a_hint(sphere):
    V, F = sphere
    with pytest.raises(ValueError, match=r"has index 42, but a has 42 vertices.*numbered from 1"):
        qs.ShapeSpace(F + 1).dist(V, 1.1 * V)
    with pytest.raises(ValueError, match=r"face \d+ refers to vertex 42, but there are only 42 vertices.*numbered from 1"):
        qs.Dataset([V[None]], F + 1)


def test_faces_with_their_vertex_array_name_face_and_index(bad_faces):
    V, F2 = bad_faces
    msg = r"faces: face 17 refers to vertex 50, but there are only 42 vertices"
    with pytest.raises(ValueError, match=msg):
        qs.ShapeSpace(F2, n_vertices=42)
    with pytest.raises(ValueError, match=msg):
        qs.ShapeSpace(F2, reference=V)
    with pytest.raises(ValueError, match=msg):
        qs.Dataset([np.stack([V, V])], F2)


def test_a_real_shape_mismatch_keeps_the_shape_message(sphere):
    V, F = sphere
    with pytest.raises(ValueError, match=r"a: expected an array of shape \(42, 3\), got \(43, 3\)"):
        qs.ShapeSpace(F).dist(np.vstack([V, V[:1]]), V)


def test_short_positions_with_good_faces_blame_the_positions(sphere):
    V, F = sphere
    with pytest.raises(ValueError, match=r"^b: expected an array of shape \(42, 3\), got \(10, 3\)"):
        qs.ShapeSpace(F).dist(V, V[:10])
