"""dth.ensemble: members on every core, the same results for any thread count."""

import numpy as np
import pytest

import dth
from conftest import EPS


def henon_heiles_shell(m, energy=1 / 8, seed=7):
    """m states on H = energy: q1 = 0, q2 and p2 drawn, p1 >= 0 solved for."""
    rng = np.random.default_rng(seed)
    states = []
    while len(states) < m:
        q2, p2 = rng.uniform(-0.4, 0.4, 2)
        v = 0.5 * q2**2 - q2**3 / 3
        rest = 2 * (energy - v) - p2**2
        if rest > 0:
            states.append([0.0, q2, np.sqrt(rest), p2])
    return np.array(states)


def test_results_are_identical_for_one_and_two_threads():
    h = dth.systems.henon_heiles()
    z0s = henon_heiles_shell(40)
    one = dth.ensemble(h, z0s, dtau=0.1, t_end=50.0, threads=1)
    two = dth.ensemble(h, z0s, dtau=0.1, t_end=50.0, threads=2)
    assert np.array_equal(one.final, two.final)
    assert np.array_equal(one.energy_error, two.energy_error)
    assert np.array_equal(one.steps, two.steps)
    assert one.failure == two.failure


def test_each_member_equals_its_own_integration():
    h = dth.systems.henon_heiles()
    z0s = henon_heiles_shell(5)
    e = dth.ensemble(h, z0s, "gauss_legendre2", dt=0.05, t_end=20.0)
    assert len(e) == 5 and e.final.shape == (5, 4) and e.failed == 0
    for z0, last, t in zip(z0s, e.final, e.t_end):
        s = dth.integrate(h, z0, "gauss_legendre2", dt=0.05, t_end=20.0)
        assert np.array_equal(s.z[-1], last) and t == 20.0


def test_dth_members_keep_their_energy():
    h = dth.systems.henon_heiles()
    e = dth.ensemble(h, henon_heiles_shell(20), dtau=0.1, t_end=100.0)
    assert e.failed == 0
    # |H| = 1/8 and terms of size ~0.1: a few eps.
    assert np.max(e.energy_error) <= 4 * EPS


def test_a_failing_member_does_not_stop_the_others():
    h = dth.systems.kepler()
    z0s = np.array([[0.5, 0.0, 0.0, 1.2], [0.5, 0.0, 0.0, 0.5 * np.sqrt(7.6)]])
    e = dth.ensemble(h, z0s, dtau=0.01, steps=3000)
    assert e.failure[0] is None
    assert e.failure[1] is not None and "break" in e.failure[1].lower()
    assert e.failed == 1 and e.steps[1] < 3000


def test_time_dependent_members_are_extended():
    h = dth.systems.forced_oscillator()
    e = dth.ensemble(h, [[1.0, 0.0], [0.5, 0.5]], dtau=0.05, t_end=3.0)
    assert e.final.shape == (2, 4) and e.failed == 0
    assert np.all(e.t_end == 3.0)


@pytest.mark.parametrize(
    "z0s, error, pattern",
    [
        (np.zeros((3, 3)), ValueError, r"z0s\[0\] has length 3, expected 4"),
        (np.zeros(4), ValueError, r"z0s has shape \(4,\), expected \(M, 4\)"),
        ("nope", TypeError, "z0s must be an"),
    ],
)
def test_bad_states_name_the_row(z0s, error, pattern):
    with pytest.raises(error, match=pattern):
        dth.ensemble(dth.systems.kepler(), z0s, dtau=0.1, steps=1)


def test_zero_threads_is_refused():
    with pytest.raises(ValueError, match="threads"):
        dth.ensemble(dth.systems.kepler(), np.zeros((1, 4)), dtau=0.1, steps=1, threads=0)
