"""Mesh objects of the Python ecosystem in and out: ``trimesh.Trimesh``, ``pyvista.PolyData`` and
``meshio.Mesh``, next to plain ``(vertices, faces)`` arrays.

Every qcshape call that takes positions or faces passes them through ``_points`` / ``_poses`` /
``_faces`` (called by the Rust extension for anything that is not a numpy array), so a mesh object
can stand wherever a (nV, 3) position array or an (nF, 3) face array is expected. The objects are
recognised by the module of their class (or of a base class) and their attributes: none of
trimesh, pyvista or meshio is imported unless one of their objects is passed in, or one of
``to_trimesh`` / ``to_pyvista`` / ``to_meshio`` is called.

pyvista faces are the flat VTK layout ``[3, a, b, c, 3, ...]``; a face with another corner count
(or triangle strips) is refused with a ``ValueError`` naming the face (qcshape does not
triangulate silently: call ``mesh.triangulate()`` first). A plain 1-D integer array in that
layout is read as faces too. meshio meshes give their "triangle" cell blocks (concatenated);
other surface cells (quad, polygon, ...) are refused, line, vertex and volume cells ignored; 2-D
points get z = 0.
"""

from __future__ import annotations

from typing import Any, Optional, Tuple

import numpy as np

__all__ = ["as_arrays", "to_meshio", "to_pyvista", "to_trimesh"]

# meshio's cell types that are surfaces but not plain triangles: refused, not ignored.
_OTHER_SURFACE_CELLS = {
    "quad",
    "quad8",
    "quad9",
    "polygon",
    "triangle6",
    "triangle7",
}


def _kind(obj: Any) -> Optional[str]:
    """"trimesh", "pyvista" or "meshio" for a mesh object of those libraries (or a subclass),
    else None; by the module names of the class hierarchy, nothing imported."""
    try:
        mro = type(obj).__mro__
    except AttributeError:  # pragma: no cover - every type has __mro__
        return None
    for cls in mro:
        top = (getattr(cls, "__module__", "") or "").split(".")[0]
        if top == "trimesh" and hasattr(obj, "vertices") and hasattr(obj, "faces"):
            return "trimesh"
        if top == "pyvista" and hasattr(obj, "points"):
            return "pyvista"
        if top == "meshio" and hasattr(obj, "points") and hasattr(obj, "cells"):
            return "meshio"
    return None


def _flat_faces(flat: Any, what: str) -> np.ndarray:
    """(nF, 3) int64 from the flat VTK face layout [3, a, b, c, 3, ...]; a face of another size
    is a ValueError naming the face."""
    flat = np.asarray(flat).ravel()
    if flat.size % 4 == 0 and flat.size > 0 and np.all(flat[::4] == 3):
        return flat.reshape(-1, 4)[:, 1:].astype(np.int64)
    # Walk the layout to name the first face that is not a triangle.
    pos, face = 0, 0
    while pos < flat.size:
        n = int(flat[pos])
        if n != 3:
            raise ValueError(
                f"faces: {what} face {face} has {n} corners, not 3: qcshape needs triangles "
                "(call mesh.triangulate() on a pyvista mesh first; qcshape.read_mesh triangulates "
                "a file's polygons and warns that it did)"
            )
        pos += 4
        face += 1
    raise ValueError(f"faces: {what} has {flat.size} entries, not a whole number of [3, a, b, c] faces")


def _pyvista_arrays(obj: Any) -> Tuple[np.ndarray, np.ndarray]:
    if not hasattr(obj, "faces"):
        raise ValueError(
            f"faces: a pyvista {type(obj).__name__} has no surface faces: pass a PolyData "
            "(e.g. mesh.extract_surface().triangulate())"
        )
    if getattr(obj, "n_strips", 0):
        raise ValueError(
            f"faces: the pyvista mesh has {obj.n_strips} triangle strip(s): call mesh.triangulate() first"
        )
    v = np.asarray(obj.points, dtype=np.float64)
    f = _flat_faces(obj.faces, "pyvista.PolyData")
    return v, f


def _meshio_arrays(obj: Any) -> Tuple[np.ndarray, np.ndarray]:
    v = np.asarray(obj.points, dtype=np.float64)
    if v.ndim == 2 and v.shape[1] == 2:
        v = np.hstack([v, np.zeros((v.shape[0], 1))])
    blocks = []
    for block in obj.cells:
        kind, data = block.type, block.data
        if kind == "triangle":
            blocks.append(np.asarray(data, dtype=np.int64).reshape(-1, 3))
        elif kind in _OTHER_SURFACE_CELLS:
            raise ValueError(
                f"faces: the meshio mesh has {len(data)} '{kind}' cells: qcshape needs triangles "
                "(triangulate them first, e.g. read the file with qcshape.read_mesh, which "
                "triangulates polygons and warns that it did)"
            )
    if not blocks:
        kinds = ", ".join(sorted({b.type for b in obj.cells})) or "none"
        raise ValueError(f"faces: the meshio mesh has no 'triangle' cells (cell types: {kinds})")
    return v, np.concatenate(blocks)


def as_arrays(obj: Any) -> Tuple[np.ndarray, np.ndarray]:
    """(V (nV, 3) float64, F (nF, 3) int64) of a trimesh.Trimesh, a pyvista.PolyData, a
    meshio.Mesh or a (V, F) pair."""
    kind = _kind(obj)
    if kind == "trimesh":
        return np.asarray(obj.vertices, dtype=np.float64), np.asarray(obj.faces, dtype=np.int64)
    if kind == "pyvista":
        return _pyvista_arrays(obj)
    if kind == "meshio":
        return _meshio_arrays(obj)
    if isinstance(obj, tuple) and len(obj) == 2:
        return np.asarray(obj[0], dtype=np.float64), _faces(obj[1])[0]
    raise ValueError(
        f"expected a (vertices, faces) pair, a trimesh.Trimesh, a pyvista.PolyData or a meshio.Mesh, "
        f"got {type(obj).__name__}"
    )


# The hooks of the Rust extension (qcshape._qcshape calls them for arguments that are not numpy
# arrays): each returns its argument unchanged unless it is a mesh object.


def _points(obj: Any) -> Any:
    """The positions of a mesh object, else obj."""
    kind = _kind(obj)
    if kind == "trimesh":
        return np.asarray(obj.vertices, dtype=np.float64)
    if kind == "pyvista":
        return np.asarray(obj.points, dtype=np.float64)
    if kind == "meshio":
        return _meshio_arrays(obj)[0]
    return obj


def _poses(obj: Any) -> Any:
    """A list or tuple of mesh objects (or arrays) as a (K, nV, 3) array, else obj."""
    if isinstance(obj, (list, tuple)) and any(_kind(x) is not None for x in obj):
        return np.stack([np.asarray(_points(x), dtype=np.float64) for x in obj])
    return obj


def _faces(obj: Any) -> Tuple[Any, Optional[int]]:
    """(faces, vertex count) of a mesh object; (obj, None) for anything else, except a 1-D
    integer array in the flat VTK layout [3, a, b, c, ...], which becomes (nF, 3)."""
    if _kind(obj) is not None:
        v, f = as_arrays(obj)
        return f, len(v)
    if isinstance(obj, np.ndarray) and obj.ndim == 1 and obj.size >= 4 and np.issubdtype(obj.dtype, np.integer):
        return _flat_faces(obj, "the flat face array"), None
    return obj, None


def _vertices_faces(vertices: Any, faces: Any) -> Tuple[np.ndarray, np.ndarray]:
    v = np.asarray(_points(vertices), dtype=np.float64)
    f = np.asarray(_faces(faces)[0], dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices: expected an array of shape (nV, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces: expected an integer array of shape (nF, 3), got {f.shape}")
    return v, f


def _many(vertices: Any, faces: Any, one: Any) -> Any:
    """one(V, F), or a list of one(V_k, F) for poses (K, nV, 3) (e.g. a geodesic's path)."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim == 3:
        return [one(*_vertices_faces(p, faces)) for p in v]
    return one(*_vertices_faces(vertices, faces))


def to_trimesh(vertices: Any, faces: Any) -> Any:
    """A trimesh.Trimesh of V (nV, 3) and F (nF, 3) (process=False: vertices kept as they are,
    none merged or reordered); for poses (K, nV, 3), a list of K of them."""
    import trimesh

    return _many(vertices, faces, lambda v, f: trimesh.Trimesh(vertices=v, faces=f, process=False))


def to_pyvista(vertices: Any, faces: Any) -> Any:
    """A pyvista.PolyData of V (nV, 3) and F (nF, 3) (flat faces [3, a, b, c, ...]); for poses
    (K, nV, 3), a list of K of them."""
    import pyvista

    def one(v: np.ndarray, f: np.ndarray) -> Any:
        flat = np.hstack([np.full((len(f), 1), 3, dtype=np.int64), f]).ravel()
        return pyvista.PolyData(v, flat)

    return _many(vertices, faces, one)


def to_meshio(vertices: Any, faces: Any) -> Any:
    """A meshio.Mesh of V (nV, 3) and F (nF, 3) (one "triangle" cell block); for poses
    (K, nV, 3), a list of K of them."""
    import meshio

    return _many(vertices, faces, lambda v, f: meshio.Mesh(v, [("triangle", f)]))


def _described(obj: Any) -> str:
    kind = _kind(obj)
    names = {"trimesh": "trimesh.Trimesh", "pyvista": "pyvista.PolyData", "meshio": "meshio.Mesh"}
    return names.get(kind or "", type(obj).__name__)


def _face_text(face: Any) -> str:
    return "[" + ", ".join(str(int(i)) for i in face) + "]"


def _on_connectivity(
    v: np.ndarray, f: np.ndarray, faces: np.ndarray, nv: int, name: str, what: str
) -> Tuple[np.ndarray, Optional[str]]:
    """The positions v of a mesh with faces f checked against the space's faces (nF, 3):
    (v, None) when the faces are the same; (v renumbered, warning) when they are the same face
    for face after renumbering the vertices (face k has the corners of the space's face k in
    the same order: a mesh whose vertices were reordered, e.g. by trimesh's processing, with
    its faces kept in order); a ValueError with the CLI's message otherwise. nv: the space's
    vertex count."""
    if f.shape != faces.shape:
        raise ValueError(
            f"{name}: shapes do not share one connectivity: {len(faces)} faces against {len(f)} "
            f"(the {what} has {len(v)} vertices and {len(f)} faces; the space {len(faces)} faces)"
        )
    differ = np.flatnonzero(np.any(f != faces, axis=1))
    if differ.size == 0:
        return v, None
    k = int(differ[0])
    refused = (
        f"{name}: shapes do not share one connectivity: face {k} is {_face_text(faces[k])} in one "
        f"and {_face_text(f[k])} in the other (the {what}'s faces differ from the space's, and no "
        "renumbering of its vertices maps them onto the space's face for face: pass a mesh with "
        "the space's connectivity, or fit one with qcshape.fit / Dataset.load(template=...))"
    )
    if len(v) < nv or f.min() < 0 or f.max() >= len(v):
        raise ValueError(refused)
    # The renumbering face order gives: vertex f[k][c] of the mesh is vertex faces[k][c] of the space.
    new_of = np.full(len(v), -1, dtype=np.int64)
    new_of[f.ravel()] = faces.ravel()
    consistent = np.array_equal(new_of[f.ravel()], faces.ravel())
    used = new_of[new_of >= 0]
    one_to_one = len(np.unique(used)) == len(used)
    if not (consistent and one_to_one and len(v) == nv and len(used) == nv):
        raise ValueError(refused)
    out = np.empty_like(v)
    out[new_of] = v
    return out, (
        f"{name}: the {what}'s vertices are numbered differently from the space's (face {k} is "
        f"{_face_text(f[k])} in it, {_face_text(faces[k])} in the space); its faces are the "
        "space's face for face after renumbering its vertices, so its positions were renumbered "
        "to the space's order"
    )


def _points_on(obj: Any, faces: np.ndarray, nv: int, name: str) -> Tuple[Any, Optional[str]]:
    """For a mesh object: (its positions in the space's vertex order, a warning or None), after
    checking its faces against the space's faces (``_on_connectivity``); anything else
    unchanged, (obj, None)."""
    if _kind(obj) is None:
        return obj, None
    v, f = as_arrays(obj)
    return _on_connectivity(v, f, faces, nv, name, _described(obj))


def _poses_on(obj: Any, faces: np.ndarray, nv: int, name: str) -> Tuple[Any, Optional[str]]:
    """A list or tuple of mesh objects (or arrays) as (K, nV, 3), each mesh checked against the
    space's faces as ``_points_on`` does (the first warning, naming the pose, is returned);
    anything else unchanged."""
    if not (isinstance(obj, (list, tuple)) and any(_kind(x) is not None for x in obj)):
        return obj, None
    out, warning = [], None
    for k, x in enumerate(obj):
        p, w = _points_on(x, faces, nv, f"{name}[{k}]")
        out.append(np.asarray(p, dtype=np.float64))
        warning = warning or w
    return np.stack(out), warning
