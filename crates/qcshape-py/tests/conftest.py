"""Shared fixtures: small generated meshes (icosphere level 1, 42 vertices) and one similarity
matrix of the synthetic benchmark, computed once per session."""

import numpy as np
import pytest

import qcshape as qs


@pytest.fixture(scope="session")
def sphere():
    return qs.icosphere(1)


@pytest.fixture(scope="session")
def pair(sphere):
    """Two shapes of one connectivity: the sphere and a bent, stretched copy."""
    V, F = sphere
    B = np.column_stack([V[:, 0] * (1.0 + 0.2 * V[:, 2]), 0.8 * V[:, 1], V[:, 2] + 0.15 * V[:, 0] ** 2])
    return V, B, F


@pytest.fixture(scope="session")
def synthetic():
    return qs.Dataset.synthetic(level=1)


# The settings of the fast matrix (and of its CLI twin in test_similarity.py).
FAST = dict(metric="isometric", steps=2)


@pytest.fixture(scope="session")
def fast_matrix(synthetic):
    return qs.similarity_matrix(synthetic, progress=False, **FAST)
