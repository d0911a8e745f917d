"""Shared fixtures: the thesis's Kepler orbit and a small lattice."""

import numpy as np
import pytest

import dth

EPS = np.finfo(float).eps


@pytest.fixture
def kepler():
    return dth.systems.kepler()


@pytest.fixture
def thesis_z0():
    # The thesis's orbit: pericentre 0.5, H = 1.44 - 2 = -0.56, e = 0.44.
    return np.array([0.5, 0.0, 0.0, 1.2])
