"""Pickle support for the Rust core's classes (e.g. to send a ShapeSpace to Dask workers)."""


def rebuild(cls, faces, kwargs):
    """``cls(faces, **kwargs)``: a ShapeSpace from the arguments it was made with."""
    return cls(faces, **kwargs)


def geodesic(state):
    """A Geodesic from the state its ``__reduce__`` gave (every field, bit for bit)."""
    from ._qcshape import Geodesic

    return Geodesic._from_state(state)
