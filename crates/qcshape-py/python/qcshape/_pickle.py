"""Pickle support for the Rust core's classes (e.g. to send a ShapeSpace to Dask workers)."""


def rebuild(cls, faces, kwargs):
    """``cls(faces, **kwargs)``: a ShapeSpace from the arguments it was made with."""
    return cls(faces, **kwargs)
