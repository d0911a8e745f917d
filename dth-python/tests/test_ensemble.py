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


def shell_state(q2, p2, energy):
    """The Henon-Heiles state q1 = 0, (q2, p2) on H = energy with p1 >= 0."""
    v = 0.5 * q2**2 - q2**3 / 3
    return [0.0, q2, np.sqrt(2 * (energy - v) - p2**2), p2]


def test_megno_tells_regular_from_chaotic_orbits_the_same_for_any_thread_count():
    h = dth.systems.henon_heiles()
    # A regular orbit at E = 1/8 and orbits of the chaotic sea at E = 1/6.
    z0s = np.array([shell_state(0.1, 0.0, 1 / 8), shell_state(-0.05, 0.0, 1 / 6),
                    shell_state(-0.25, 0.1, 1 / 6)])
    one = dth.ensemble(h, z0s, dtau=0.05, t_end=1000.0, megno=True, threads=1)
    two = dth.ensemble(h, z0s, dtau=0.05, t_end=1000.0, megno=True, threads=2)
    assert one.megno.shape == one.lyapunov.shape == (3,)
    assert np.array_equal(one.megno, two.megno) and np.array_equal(one.lyapunov, two.lyapunov)
    # <Y> -> 2 on a quasi-periodic orbit (slowly: within a few tenths at t = 1000), and grows
    # like lambda t / 2 on a chaotic one (lambda ~ 0.1 here: tens).
    assert 1.5 < one.megno[0] < 3.0
    assert np.all(one.megno[1:] > 10.0)
    assert one.lyapunov[0] < 0.02 and np.all(one.lyapunov[1:] > 0.05)


def test_the_indicators_are_the_scene_ensembles_observer_on_each_member():
    # One member through `ensemble` and the same run through `integrate`: MEGNO is computed
    # from the states the run produces, so a member's indicator does not depend on the others.
    h = dth.systems.henon_heiles()
    z0s = np.array([shell_state(0.2, 0.05, 1 / 6), shell_state(0.1, 0.0, 1 / 8)])
    both = dth.ensemble(h, z0s, "rk4", dt=0.02, t_end=200.0, lyapunov=True)
    alone = dth.ensemble(h, z0s[1:], "rk4", dt=0.02, t_end=200.0, lyapunov=True)
    assert both.megno is not None and both.megno[1] == alone.megno[0]
    assert both.lyapunov[1] == alone.lyapunov[0]
    plain = dth.ensemble(h, z0s, "rk4", dt=0.02, t_end=1.0)
    assert plain.megno is None and plain.lyapunov is None


def test_a_parameter_grid_runs_one_member_per_value():
    text = "p1^2/2 + k*q1^2/2 + e*q1^4/4"
    h = dth.Hamiltonian(text, params={"k": 1.0, "e": 0.0})
    es = np.linspace(0.0, 0.6, 7)
    one = dth.ensemble(h, [1.0, 0.0], params={"e": es}, dtau=0.05, t_end=10.0, threads=1)
    two = dth.ensemble(h, [1.0, 0.0], params={"e": es}, dtau=0.05, t_end=10.0, threads=2)
    assert one.final.shape == (7, 2) and one.failed == 0
    assert np.array_equal(one.final, two.final)
    for e, last in zip(es, one.final):
        alone = dth.Hamiltonian(text, params={"k": 1.0, "e": e})
        s = dth.integrate(alone, [1.0, 0.0], dtau=0.05, t_end=10.0)
        assert np.array_equal(s.z[-1], last)
    # The Hamiltonian itself keeps its parameters.
    assert h.params == {"k": 1.0, "e": 0.0}


def test_a_grid_over_two_parameters_pairs_them_and_takes_a_state_per_member():
    h = dth.systems.kepler()
    m, k = np.meshgrid([0.5, 1.0], [1.0, 2.0])
    z0s = np.array([[0.5, 0.0, 0.0, 1.2], [0.5, 0.0, 0.0, 1.1], [0.6, 0.0, 0.0, 1.5], [0.5, 0.0, 0.0, 2.0]])
    e = dth.ensemble(h, z0s, params={"m": m.ravel(), "k": k.ravel()}, dtau=0.05, orbits=1)
    assert e.failed == 0
    for i in range(4):
        alone = dth.systems.kepler(m=m.ravel()[i], k=k.ravel()[i])
        s = dth.integrate(alone, z0s[i], dtau=0.05, orbits=1)
        # Each member's orbits are its own period, from its parameters and state.
        assert e.t_end[i] == s.t[-1] and np.array_equal(e.final[i], s.z[-1])


def test_the_catalogue_methods_run_in_ensembles():
    h = dth.systems.kepler()
    z0s = np.array([[0.5, 0.0, 0.0, 1.2], [0.7, 0.0, 0.0, 1.1]])
    e = dth.ensemble(h, z0s, "exact", dt=0.1, orbits=2)
    assert np.max(np.abs(e.final - z0s)) < 1e-12
    dm = dth.ensemble(h, z0s, "discrete_mechanics", dt=0.05, t_end=3.0)
    assert dm.failed == 0 and np.max(dm.energy_error) <= 16 * EPS * 2


@pytest.mark.parametrize(
    "params, z0s, pattern",
    [
        ({"x": [1.0]}, [1.0, 0.0], "params: unknown parameter `x`: the Hamiltonian has k"),
        ({"k": [1.0, 2.0]}, np.zeros((3, 2)), "z0s has 3 rows and params 2 values"),
        ({}, [1.0, 0.0], "params is empty"),
        ({"k": [1.0, float("nan")]}, [1.0, 0.0], r"params\[\"k\"\]\[1\]: .*not finite"),
    ],
)
def test_bad_grids_name_what_is_wrong(params, z0s, pattern):
    h = dth.Hamiltonian("p1^2/2 + k*q1^2/2", params={"k": 1.0})
    with pytest.raises(ValueError, match=pattern):
        dth.ensemble(h, z0s, params=params, dtau=0.1, steps=1)


def test_grids_of_unequal_lengths_are_refused():
    h = dth.Hamiltonian("p1^2/2 + k*q1^2/2 + e*q1^4", params={"k": 1.0, "e": 0.0})
    with pytest.raises(ValueError, match="`k` has 3 values and `e` 2"):
        dth.ensemble(h, [1.0, 0.0], params={"e": [0.0, 1.0], "k": [1.0, 2.0, 3.0]}, dtau=0.1, steps=1)


def test_orbits_in_an_ensemble_name_the_member_without_a_period():
    z0s = np.array([[0.5, 0.0, 0.0, 1.2], [0.5, 0.0, 0.0, 3.0]])
    with pytest.raises(ValueError, match="member 1: orbits=.*unbound"):
        dth.ensemble(dth.systems.kepler(), z0s, dtau=0.1, orbits=1)


def test_megno_is_the_scene_ensembles_to_the_bit():
    # The same two members as a `dth run` ensemble scene (the catalogue's compiled system,
    # `chaos = "megno"`) and from Python (the text, at the same fixed size): the same
    # trajectories and the same observer, so the same indicators to the last bit.
    scene = '''
[system]
name = "henon_heiles"
[initial]
q = [0.0, 0.0]
p = [0.0, 0.0]
[ensemble]
kind = "list"
members = """
q2, p1, p2
0.1, 0.45, 0.0
-0.25, 0.5, 0.1
"""
chaos = "megno"
[[method]]
kind = "dth"
dtau = 0.05
[duration]
time = 200.0
'''
    table = dth.run_scene(scene).arrays["ensemble"]
    z0s = np.array([[0.0, 0.1, 0.45, 0.0], [0.0, -0.25, 0.5, 0.1]])
    e = dth.ensemble(dth.systems.henon_heiles(), z0s, dtau=0.05, t_end=200.0, megno=True)
    assert np.array_equal(e.megno, table["megno"])
    assert np.array_equal(e.lyapunov, table["lyapunov"])
    ends = np.column_stack([table[f"end_{c}"] for c in ("q1", "q2", "p1", "p2")])
    assert np.array_equal(e.final, ends)


# Pericentre 0.5 in the thesis normalisation (|p|^2 = 1 + e) at e = 0.9, 0.99, 0.999.
ECCENTRIC = np.array([[0.5, 0.0, 0.0, np.sqrt(1 + e)] for e in (0.9, 0.99, 0.999)])


def test_regularize_runs_each_member_as_integrate_does(kepler):
    # Unregularized, plain DTH breaks down near the first pericentre passage of every member.
    plain = dth.ensemble(kepler, ECCENTRIC, dtau=0.05, t_end=100.0)
    assert plain.failed == 3
    e = dth.ensemble(kepler, ECCENTRIC, dtau=0.05, order=8, t_end=100.0, regularize="levi-civita")
    assert e.failed == 0 and e.final.shape == (3, 4)
    assert (e.fallback_steps == 0).all()
    for i, z0 in enumerate(ECCENTRIC):
        s = dth.integrate(kepler, z0, dtau=0.05, order=8, t_end=100.0, regularize="levi-civita")
        # The same run, to the bit: physical end state and time, K's steps. The time lands on
        # T within the stepper's landing tolerance, 4 eps T (the rounding of its time sum).
        assert np.array_equal(e.final[i], s.z[-1]) and e.t_end[i] == s.t[-1]
        assert abs(s.t[-1] - 100.0) <= 4 * EPS * 100.0
        assert e.steps[i] == s.steps
        # |H - H(z0)| of the physical H, against the terms |p|^2 + 1/r (at most 4 at
        # pericentre, eps of which is 9e-16).
        assert e.energy_error[i] == np.abs(s.energy_error).max()
        assert e.energy_error[i] < 4e-15


def test_regularize_with_a_parameter_grid_gives_each_member_its_own_k():
    text = "p1^2 + p2^2 - k*(q1^2 + q2^2)^(-1/2)"
    ks = np.array([1.0, 1.5, 3.0])
    e = dth.ensemble(dth.Hamiltonian(text, params={"k": 1.0}), ECCENTRIC[1], dtau=0.05,
                     order=8, t_end=50.0, params={"k": ks}, regularize="levi-civita", threads=2)
    assert e.failed == 0
    for i, k in enumerate(ks):
        s = dth.integrate(dth.Hamiltonian(text, params={"k": k}), ECCENTRIC[1], dtau=0.05,
                          order=8, t_end=50.0, regularize="levi-civita")
        assert np.array_equal(e.final[i], s.z[-1]) and e.steps[i] == s.steps
        assert e.energy_error[i] == np.abs(s.energy_error).max()
    # The members differ: k is K's parameter too, not only H's.
    assert not np.array_equal(e.final[0], e.final[1])


def test_regularize_in_an_ensemble_says_what_it_cannot_do(kepler):
    with pytest.raises(ValueError, match="regularize with megno"):
        dth.ensemble(kepler, ECCENTRIC, dtau=0.05, steps=5, megno=True, regularize="levi-civita")
    with pytest.raises(ValueError, match="applies to method \"dth\""):
        dth.ensemble(kepler, ECCENTRIC, "gauss_legendre2", dt=0.01, steps=5,
                     regularize="levi-civita")
    with pytest.raises(ValueError, match="regularizes a Hamiltonian of n = 3"):
        dth.ensemble(kepler, ECCENTRIC, dtau=0.05, steps=5, regularize="ks")
    with pytest.raises(TypeError, match="give regularize too"):
        dth.ensemble(kepler, ECCENTRIC, dtau=0.05, steps=5, centre=[0.0, 0.0])
    # A member at the centre: its row, named.
    with pytest.raises(ValueError, match=r"member 1|z0s\[1\]"):
        dth.ensemble(kepler, [ECCENTRIC[0], [0.0, 0.0, 0.0, 1.0]], dtau=0.05, steps=5,
                     regularize="levi-civita")
