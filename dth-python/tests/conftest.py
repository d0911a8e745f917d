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


KEPLER_SCENE = """
[system]
name = "kepler"
params = {{ m = 0.5, k = 1.0 }}
[initial]
q = [0.5, 0.0]
p = [0.0, 1.2]
[[method]]
{method}
[duration]
{duration}
[[effect]]
kind = "trajectory"
"""


def kepler_scene_trajectory(duration, method='kind = "dth"\ndtau = 0.06277'):
    """The times and states of the thesis's Kepler orbit run as a scene of the catalogue's
    `kepler` for `duration` (a `[duration]` line) with `method` (the `[[method]]` lines; DTH
    with dtau = 0.06277 by default), every digit."""
    run = dth.run_scene(KEPLER_SCENE.format(duration=duration, method=method))
    (name,) = [n for n in run.arrays if "trajectory" in n]
    table = run.arrays[name]
    columns = ["q1", "q2", "p1", "p2"]
    assert all(c in table for c in columns), list(table)
    return np.asarray(table["t"]), np.column_stack([table[c] for c in columns])
