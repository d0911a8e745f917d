"""dth.integrate: DTH and every peer through one call; shapes, guarantees, failures, errors."""

from fractions import Fraction

import numpy as np
import pytest

import dth
from conftest import EPS, kepler_scene_trajectory

# Pericentre 0.5 with e = 0.9 (m = 1/2, k = 1): p = m v, v^2 = (k/m)(1 + e)/r.
E09 = np.array([0.5, 0.0, 0.0, 0.5 * np.sqrt(2 * 1.9 / 0.5)])

PEERS = ["midpoint", "gauss_legendre2", "stormer_verlet", "rk4", "trapezoidal", "discrete_gradient"]
# The methods that run on the catalogue system of a dth.systems Hamiltonian.
CATALOGUE_METHODS = ["discrete_mechanics", "exact"]


def test_methods_lists_every_method():
    assert set(dth.METHODS) == {"dth", *PEERS, *CATALOGUE_METHODS}


def kepler_period(z0, m=0.5, k=1.0):
    """2 pi sqrt(m a^3 / k), a = -k / (2 H)."""
    energy = (z0[2] ** 2 + z0[3] ** 2) / (2 * m) - k / np.hypot(z0[0], z0[1])
    a = -k / (2 * energy)
    return 2 * np.pi * np.sqrt(m * a**3 / k)


def test_orbits_ends_after_that_many_periods(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.06, orbits=2.5, t0=1.0)
    expected = 1.0 + 2.5 * kepler_period(thesis_z0)
    # The period is a handful of operations on numbers of order one: a few eps.
    assert abs(s.t[-1] - expected) <= 8 * EPS * expected
    assert s.kinds[-1] == "shortened"
    spring = dth.systems.harmonic_oscillator(m=2.0, k=0.5)
    s = dth.integrate(spring, [1.0, 0.0], "midpoint", dt=0.1, orbits=3)
    assert abs(s.t[-1] - 3 * 2 * np.pi * np.sqrt(2.0 / 0.5)) <= 8 * EPS * s.t[-1]


def test_orbits_is_the_dth_commands_duration_to_the_bit():
    # The scene runs the catalogue's Kepler for 1 orbit, which the `dth` command turns into
    # a time from the system's period; Python's orbits=1 is the same time, so the same run.
    t, z = kepler_scene_trajectory("orbits = 1")
    s = dth.integrate(dth.systems.kepler(), [0.5, 0.0, 0.0, 1.2], dtau=0.06277, orbits=1)
    assert np.array_equal(t, s.t) and np.array_equal(z, s.z)


@pytest.mark.parametrize(
    "h, z0, pattern",
    [
        (dth.systems.henon_heiles(), [0.0, 0.1, 0.3, 0.0], "dth.systems.henon_heiles has none"),
        (dth.Hamiltonian("p1^2/2 + q1^2/2"), [1.0, 0.0], "built from text has none"),
        (dth.systems.kepler(), [0.5, 0.0, 0.0, 3.0], "no orbit period .*unbound"),
    ],
)
def test_orbits_without_a_period_says_what_to_give_instead(h, z0, pattern):
    with pytest.raises(ValueError, match=pattern) as info:
        dth.integrate(h, z0, dtau=0.1, orbits=1)
    assert "give t_end=... (a time) or steps=... instead" in str(info.value)


def test_orbits_is_one_duration_among_three(kepler, thesis_z0):
    with pytest.raises(TypeError, match="exactly one of steps=.*orbits="):
        dth.integrate(kepler, thesis_z0, dtau=0.1, orbits=1, t_end=2.0)
    with pytest.raises(ValueError, match="orbits must be a finite number"):
        dth.integrate(kepler, thesis_z0, dtau=0.1, orbits=-1)


def test_exact_samples_keplers_solution(kepler, thesis_z0):
    period = kepler_period(thesis_z0)
    s = dth.integrate(kepler, thesis_z0, "exact", dt=period / 40, orbits=3)
    assert s.method == "exact" and s.kinds[1:] == ["fixed"] * (len(s) - 1)
    assert np.allclose(s.t, np.arange(len(s)) * period / 40, rtol=0, atol=8 * EPS * s.t[-1])
    # After whole orbits the state is the initial one: Kepler's equation solved to roundoff
    # (a few eps of the mean anomaly 6 pi, times the size of the state's derivatives ~ 3).
    assert np.max(np.abs(s.z[-1] - thesis_z0)) <= 256 * EPS * 6 * np.pi
    # Energy and angular momentum along the way, to roundoff.
    assert np.max(np.abs(s.energy_error)) <= 16 * EPS * 2
    angular = s.z[:, 0] * s.z[:, 3] - s.z[:, 1] * s.z[:, 2]
    assert np.max(np.abs(angular - 0.6)) <= 256 * EPS


def test_exact_is_the_scene_runners_exact_to_the_bit(kepler, thesis_z0):
    # Both sample Kepler's solution from z0 at t = k dt and land on the end time.
    t, z = kepler_scene_trajectory("time = 3.05", 'kind = "exact"\ndt = 0.1')
    s = dth.integrate(kepler, thesis_z0, "exact", dt=0.1, t_end=3.05)
    assert s.t[-1] == 3.05
    assert np.array_equal(t, s.t) and np.array_equal(z, s.z)


def test_exact_agrees_with_gauss_legendre_to_its_error(kepler, thesis_z0):
    exact = dth.integrate(kepler, thesis_z0, "exact", dt=0.5, t_end=2.0)
    gl = dth.integrate(kepler, thesis_z0, "gauss_legendre2", dt=1e-3, t_end=2.0)
    # Fourth order: C dt^4 with C ~ 10 here.
    assert np.max(np.abs(exact.z[-1] - gl.z[-1])) < 1e-10


def test_the_free_particles_exact_solution_is_straight_lines():
    h = dth.systems.free_particle(m=2.0)
    s = dth.integrate(h, [1.0, -1.0, 0.5, 0.25], "exact", dt=0.1, steps=10)
    assert np.allclose(s.z[-1], [1.0 + 0.5 * 1.0 / 2.0, -1.0 + 0.25 / 2.0, 0.5, 0.25], rtol=0, atol=4 * EPS)


def test_discrete_mechanics_conserves_energy_and_angular_momentum(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, "discrete_mechanics", dt=0.05, orbits=5)
    assert s.method == "discrete_mechanics" and s.completed
    assert np.max(np.abs(s.energy_error)) <= 16 * EPS * 2
    angular = s.z[:, 0] * s.z[:, 3] - s.z[:, 1] * s.z[:, 2]
    assert np.max(np.abs(angular - 0.6)) <= 64 * EPS


def test_discrete_mechanics_is_second_order_against_the_exact_solution(kepler, thesis_z0):
    errors = []
    for dt in (0.02, 0.01):
        dm = dth.integrate(kepler, thesis_z0, "discrete_mechanics", dt=dt, t_end=2.0)
        exact = dth.integrate(kepler, thesis_z0, "exact", dt=dt, t_end=2.0)
        errors.append(np.max(np.abs(dm.z[-1] - exact.z[-1])))
    assert 3.5 < errors[0] / errors[1] < 4.5


@pytest.mark.parametrize("method", CATALOGUE_METHODS)
def test_the_catalogue_methods_name_the_method_and_the_system(method):
    with pytest.raises(ValueError, match=f'method="{method}".*dth.systems.henon_heiles has none'):
        dth.integrate(dth.systems.henon_heiles(), [0.0, 0.1, 0.3, 0.0], method, dt=0.1, steps=1)
    with pytest.raises(ValueError, match=f'method="{method}".*built from text has none'):
        dth.integrate(dth.Hamiltonian("p1^2/2 + p2^2/2 - (q1^2 + q2^2)^(-1/2)"), [0.5, 0.0, 0.0, 1.2],
                      method, dt=0.1, steps=1)
    with pytest.raises(TypeError, match=f'dtau is an option of method="dth"; method="{method}" takes dt'):
        dth.integrate(dth.systems.kepler(), [0.5, 0.0, 0.0, 1.2], method, dtau=0.1, steps=1)


def test_exact_needs_an_elliptic_kepler_orbit(kepler):
    with pytest.raises(ValueError, match='method="exact": .*elliptic orbits only'):
        dth.integrate(kepler, [0.5, 0.0, 0.0, 3.0], "exact", dt=0.1, steps=1)


def test_dth_keeps_the_energy_at_every_midpoint(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.06277, steps=2000)
    assert s.completed and s.failure is None
    assert s.energy0 == kepler.value(thesis_z0)
    # The midpoint equation is solved against H(zbar_0): roundoff of terms of size ~2.
    assert np.max(np.abs(s.energy_error)) <= 4 * EPS * 2
    for z in s.z[::97]:
        assert abs(kepler.value(z) - s.energy0) <= 4 * EPS * 2


def test_shapes_and_dtypes(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, steps=50)
    assert len(s) == 51
    assert s.t.shape == (51,) and s.t.dtype == np.float64
    assert s.z.shape == (51, 4) and s.z.dtype == np.float64
    assert s.k.shape == (51,) and s.k[-1] == 50
    assert s.energy_error.shape == (51,)
    for a in (s.lam, s.vertex_t, s.psi):
        assert a.shape == (51,)
    assert s.vertices.shape == (51, 4)
    assert s.kinds[0] == "initial" and set(s.kinds[1:]) == {"dth"}
    assert np.array_equal(s.z[0], thesis_z0)
    assert s.steps == 50 and s.fallback_steps == 0 and s.newton_iterations > 0
    assert "Solution(method=\"dth\"" in repr(s)


def test_dth_ends_exactly_at_t_end(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.07, t_end=3.0)
    assert s.t[-1] == 3.0
    assert s.kinds[-1] == "shortened"
    assert np.all(np.diff(s.t) > 0)


def test_every_saves_every_nth_state_and_the_last(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, steps=95, every=10)
    assert s.k.tolist() == list(range(0, 100, 10)) + [95]
    full = dth.integrate(kepler, thesis_z0, dtau=0.05, steps=95)
    assert np.array_equal(s.z, full.z[s.k])


@pytest.mark.parametrize("method", PEERS)
def test_every_peer_lands_on_t_end(method, kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, method, dt=0.01, t_end=1.234)
    assert s.completed
    assert s.method == method
    assert s.t[-1] == 1.234
    assert s.lam is None and s.vertices is None and s.psi is None
    assert set(s.kinds[1:]) == {"fixed"}
    # Each is consistent: after ~1.2 time units at dt = 0.01 the energy has moved little.
    assert np.max(np.abs(s.energy_error)) < 1e-3


def test_the_discrete_gradient_conserves_energy(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, "discrete_gradient", dt=0.05, steps=500)
    assert np.max(np.abs(s.energy_error)) <= 8 * EPS * 2


def test_save_at_lands_on_each_time(kepler, thesis_z0):
    times = [0.5, 1.0, 2.25]
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, t_end=3.0, save_at=times)
    # DTH lands on a time within the rounding of its time sum, 4 eps t_end.
    assert np.max(np.abs(s.t - (times + [3.0]))) <= 4 * EPS * 3.0
    # Beside the run: the run itself, and so its end, is the one without chosen times.
    plain = dth.integrate(kepler, thesis_z0, dtau=0.05, t_end=3.0, every=10**9)
    assert s.z[-1].tolist() == plain.z[-1].tolist()
    # A fixed-step method lands on the times themselves.
    m = dth.integrate(kepler, thesis_z0, "midpoint", dt=0.1, t_end=3.0, save_at=times)
    assert m.t.tolist() == times + [3.0]
    with pytest.raises(TypeError, match="every or save_at"):
        dth.integrate(kepler, thesis_z0, dtau=0.05, t_end=3.0, save_at=times, every=2)


def _final(h, z0, order, dtau, t_end):
    return dth.integrate(h, z0, dtau=dtau, order=order, t_end=t_end, every=10**9).z[-1]


@pytest.mark.parametrize("order", [2, 4, 6, 8])
def test_dth_converges_at_its_order(order, kepler, thesis_z0):
    # Differences of successive halvings shrink by 2^order (Richardson): the observed order
    # within 0.5 of the nominal one, on the thesis orbit over half a period.
    # The bases are in each order's asymptotic range and above the roundoff floor (order 8
    # at 0.025 differs by ~2e-11, a thousand times the roundoff of states of size ~1).
    base = {2: 0.02, 4: 0.04, 6: 0.08, 8: 0.1}[order]
    finals = [_final(kepler, thesis_z0, order, base / 2**j, 1.5) for j in range(3)]
    d1 = np.max(np.abs(finals[0] - finals[1]))
    d2 = np.max(np.abs(finals[1] - finals[2]))
    observed = np.log2(d1 / d2)
    assert abs(observed - order) < 0.5, (d1, d2, observed)


def test_plain_dth_breaks_down_on_an_eccentric_orbit_and_keeps_the_partial_run(kepler):
    z0 = E09
    s = dth.integrate(kepler, z0, dtau=0.01, steps=5000)
    assert not s.completed
    assert s.failure_kind == "Breakdown"
    assert len(s) > 1 and s.steps == len(s) - 1


def test_robust_mode_counts_its_fallback_steps(kepler):
    z0 = E09
    s = dth.integrate(kepler, z0, dtau=0.01, robust=True, steps=3000)
    assert s.completed
    assert s.fallback_steps > 0
    assert s.kinds.count("fallback") == s.fallback_steps
    assert np.max(np.abs(s.energy_error)) <= 16 * EPS * 8


def test_raise_on_failure_carries_the_partial_solution(kepler):
    z0 = E09
    with pytest.raises(dth.IntegrationError) as info:
        dth.integrate(kepler, z0, dtau=0.01, steps=5000, raise_on_failure=True)
    e = info.value
    assert isinstance(e, RuntimeError)
    assert e.kind == "Breakdown"
    assert isinstance(e.solution, dth.Solution) and len(e.solution) > 1


def test_a_step_cap_is_a_failure(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, t_end=100.0, max_steps=10)
    assert s.failure_kind == "StepCap"
    assert s.steps == 10


def test_without_energy_errors(kepler, thesis_z0):
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, steps=10, energy_errors=False)
    assert s.energy_error.shape == (0,)


def test_a_time_dependent_hamiltonian_runs_in_extended_phase_space():
    h = dth.systems.forced_oscillator()
    assert h.dim == 4  # z = (q1, t, p1, p_t)
    # The physical state (q1, p1) is extended with t0 and p_t = -H(q1, p1, t0).
    s = dth.integrate(h, [1.0, 0.0], dtau=0.05, t_end=5.0, t0=0.5)
    assert s.completed and s.t[-1] == 5.0
    h0 = 0.5 - 0.1 * np.cos(1.3 * 0.5)
    assert s.z[0].tolist() == [1.0, 0.5, 0.0, -h0]
    # The extended energy stays at zero to roundoff.
    assert np.max(np.abs(s.energy_error)) <= 8 * EPS
    # Given whole, the extended state must be on calH = 0.
    with pytest.raises(ValueError, match="p_t = -H"):
        dth.integrate(h, [1.0, 0.0, 0.0, 0.0], dtau=0.05, t_end=5.0)


@pytest.mark.parametrize(
    "kwargs, error, pattern",
    [
        ({"steps": 10}, TypeError, "needs dtau"),
        ({"dtau": 0.1, "dt": 0.1, "steps": 10}, TypeError, "DTH takes dtau"),
        ({"dtau": 0.1}, TypeError, "exactly one of steps"),
        ({"dtau": 0.1, "steps": 10, "t_end": 1.0}, TypeError, "exactly one of steps"),
        ({"dtau": 0.1, "steps": 10, "every": 0}, ValueError, "every must be at least 1"),
        ({"dtau": -0.1, "steps": 10}, ValueError, "dtau"),
        ({"dtau": 0.1, "order": 3, "steps": 10}, ValueError, "order"),
        ({"dtau": 0.1, "steps": 10, "save_at": [0.5]}, TypeError, "save_at"),
    ],
)
def test_bad_arguments_name_the_argument(kwargs, error, pattern, kepler, thesis_z0):
    with pytest.raises(error, match=pattern):
        dth.integrate(kepler, thesis_z0, **kwargs)


def test_dth_options_given_to_a_peer_are_refused(kepler, thesis_z0):
    with pytest.raises(TypeError, match='dtau is an option of method="dth"'):
        dth.integrate(kepler, thesis_z0, "midpoint", dtau=0.1, steps=10)
    with pytest.raises(TypeError, match='method="rk4" needs dt'):
        dth.integrate(kepler, thesis_z0, "rk4", steps=10)


def test_an_unknown_method_suggests_the_closest(kepler, thesis_z0):
    with pytest.raises(ValueError, match='unknown method "dht" \\(did you mean "dth"\\?\\)'):
        dth.integrate(kepler, thesis_z0, "dht", dtau=0.1, steps=1)


def test_a_non_finite_initial_state_is_a_value_error(kepler):
    with pytest.raises(ValueError, match="(?i)finite"):
        dth.integrate(kepler, [np.nan, 0.0, 0.0, 1.0], dtau=0.1, steps=1)


def test_a_state_of_the_wrong_length_names_z0(kepler):
    with pytest.raises(ValueError, match="z0 has length 2, expected 4"):
        dth.integrate(kepler, [0.5, 0.0], dtau=0.1, steps=1)


def test_the_hamiltonian_must_be_one(thesis_z0):
    with pytest.raises(TypeError):
        dth.integrate("p1^2", thesis_z0, dtau=0.1, steps=1)


def radius(z):
    return float(np.hypot(z[0], z[1]))


def test_an_event_is_located_on_the_methods_own_states(kepler, thesis_z0):
    # r > 1 from the thesis's pericentre (0.5; apocentre 1.29): the exact solution locates it
    # to roundoff, DTH of order 8 to its own (tiny) error.
    when = {"far": "q1^2 + q2^2 > 1"}
    exact = dth.integrate(kepler, thesis_z0, "exact", dt=0.05, t_end=5.0, events=when, stop_on="far")
    dth8 = dth.integrate(kepler, thesis_z0, dtau=0.02, order=8, t_end=5.0, events=when, stop_on="far")
    for s in (exact, dth8):
        assert s.completed and s.stopped == "far"
        name, t, z = s.events[0]
        assert name == "far" and len(s.events) == 1
        # The run ends on the event: its last state is the event's, bit for bit.
        assert s.t[-1] == t and np.array_equal(s.z[-1], z)
        # r = 1 to roundoff (r^2 - 1 is located to 8 eps in t; dr/dt is of order 1).
        assert abs(radius(z) - 1.0) < 1e-13
    assert abs(dth8.events[0][1] - exact.events[0][1]) < 1e-9


def test_a_recorded_event_leaves_the_run_as_it_was(kepler, thesis_z0):
    # Every orbit crosses r = 1 outwards once: three orbits, three events.
    plain = dth.integrate(kepler, thesis_z0, dtau=0.05, orbits=3)
    s = dth.integrate(kepler, thesis_z0, dtau=0.05, orbits=3, events={"out": "q1^2 + q2^2 > 1"})
    assert [e[0] for e in s.events] == ["out"] * 3 and s.stopped is None
    assert all(abs(radius(z) - 1.0) < 1e-13 for _, _, z in s.events)
    assert np.array_equal(s.z, plain.z) and np.array_equal(s.t, plain.t)


def test_an_event_on_time_and_a_peer(thesis_z0, kepler):
    # `t` is the run's time, for an autonomous H too; a peer lands on it as DTH does.
    for method, step in [("dth", {"dtau": 0.05}), ("midpoint", {"dt": 0.1})]:
        s = dth.integrate(kepler, thesis_z0, method, t_end=5.0, events={"late": "t > 1.25"}, stop_on=["late"], **step)
        assert s.stopped == "late"
        assert abs(s.t[-1] - 1.25) <= 8 * EPS * 1.25


@pytest.mark.parametrize(
    "events, stop_on, pattern",
    [
        ({"r": "q1^2 + q2^2"}, None, "event `r`: expected one comparison"),
        ({"r": "q1 < 1 < q2"}, None, "event `r`: expected one comparison"),
        ({"r": "q1 <"}, None, "event `r`: a side of the comparison is empty"),
        ({"r": "q3 < 1"}, None, "event `r`"),
        ({"r": "q1 < 1"}, "s", "stop_on names `s`, which is not one of the events \\(r\\)"),
        (None, "s", "stop_on names `s`.*none given"),
    ],
)
def test_a_bad_event_is_a_value_error_naming_it(events, stop_on, pattern, kepler, thesis_z0):
    with pytest.raises(ValueError, match=pattern):
        dth.integrate(kepler, thesis_z0, dtau=0.05, t_end=1.0, events=events, stop_on=stop_on)


# Pericentre 0.5 with e = 0.99 in the thesis normalisation: |p|^2 = 1 + e; period 500 pi.
E099 = np.array([0.5, 0.0, 0.0, np.sqrt(1.99)])


def test_regularize_runs_dth_through_an_eccentric_orbit_in_physical_coordinates(kepler):
    # Unregularized, plain DTH breaks down near the first pericentre passage.
    plain = dth.integrate(kepler, E099, dtau=0.05, orbits=1)
    assert plain.failure_kind == "Breakdown"
    s = dth.integrate(kepler, E099, dtau=0.05, order=8, orbits=10, regularize="levi-civita")
    assert s.completed and s.fallback_steps == 0
    assert s.z.shape[1] == 4 and s.vertices.shape[1] == 4
    # The physical end: K's t coordinate lands on it to its rounding over ~6,000 steps.
    assert abs(s.t[-1] - 10 * 500 * np.pi) <= 1e-12 * 10 * 500 * np.pi
    # |H - E| against the terms |p|^2 + 1/r (3.99 at pericentre, eps of which is 9e-16).
    assert np.abs(s.energy_error).max() < 4e-15
    # The energy the run starts from is H(z0) rounded once (evaluated in double-double; the
    # plain sum rounds |p|^2 first): here H(z0) = p^2 - 2 exactly (1/r = 2).
    exact = float(Fraction(float(E099[3])) ** 2 - 2)
    assert s.energy0 == exact != kepler.value(E099)
    # Order 8 is back at pericentre after 10 orbits.
    assert np.abs(s.z[-1] - E099).max() < 1e-8
    # lam is the physical dt/dtau: the saved times advance by about it.
    assert (s.lam > 0).all()
    steps = np.diff(s.t[:-1])
    assert np.allclose(steps, 0.05 * (s.lam[:-2] + s.lam[1:-1]) / 2, rtol=1e-2)


def test_double_double_reaches_1e_10_at_e0999_where_doubles_stop_at_1e_9(kepler):
    # The thesis orbit at e = 0.999 over 100 orbits, DTH-8 at 91 steps per orbit (a quarter
    # period of K's oscillator of angular frequency sqrt(-E) is half an orbit). The exact state
    # at T is Kepler's equation at 50 digits for the start as stored
    # (dth-examples/benches/ias15_kepler.py, kepler_state), as the Rust test
    # a_run_in_double_double_reaches_1e_10_at_e0999 takes it: measured 1.3e-11 in
    # double-double, 1.8e-9 from doubles.
    z0 = np.array([0.5, 0.0, 0.0, np.sqrt(1.999)])
    energy = float(kepler.value(z0))
    a = -1.0 / (2.0 * energy)
    t_end = 100 * (2 * np.pi * np.sqrt(a * a * a / 2.0))
    assert t_end == 4967294.132900526
    exact = np.array(
        [0.49999999999888106, 1.4955934453998533e-06, -2.1156175047818246e-06, 1.413859964774112]
    )
    dtau = np.pi / np.sqrt(-energy) / 91
    common = dict(dtau=dtau, order=8, t_end=t_end, every=10**9, regularize="levi-civita")
    dd = dth.integrate(kepler, z0, double_double=True, **common)
    assert dd.completed and dd.fallback_steps == 0 and dd.t[-1] == t_end
    assert np.abs(dd.z[-1] - exact).max() <= 1e-10
    doubles = dth.integrate(kepler, z0, **common)
    assert np.abs(doubles.z[-1] - exact).max() > 1e-10
    with pytest.raises(TypeError, match="give regularize too"):
        dth.integrate(kepler, z0, dtau=0.1, steps=1, double_double=True)


def test_regularize_is_the_scenes_regularization_to_the_bit():
    text = "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)"
    t_end = 2 * 500 * np.pi
    s = dth.integrate(dth.Hamiltonian(text), E099, dtau=0.3, t_end=t_end, regularize="levi-civita")
    scene = f"""
[system]
hamiltonian = "{text}"
regularize = "levi-civita"
[initial]
q = [0.5, 0.0]
p = [0.0, {float(E099[3])!r}]
[[method]]
kind = "dth"
dtau = 0.3
[duration]
time = {t_end!r}
[[effect]]
kind = "final_state"
"""
    method = dth.run_scene(scene).summary["methods"][0]
    assert method["fallback"]["steps"] == 0 and method["steps"] == s.steps
    assert method["final_state"]["t"] == s.t[-1]
    assert method["final_state"]["z"] == list(s.z[-1])


def test_regularize_in_space_keeps_the_orbit_and_its_energy():
    h = dth.Hamiltonian("p1^2 + p2^2 + p3^2 - (q1^2 + q2^2 + q3^2)^(-1/2)")
    # An inclined orbit at e = 0.99 from pericentre 0.5.
    v = np.sqrt(1.99)
    z0 = np.array([0.5, 0.0, 0.0, 0.0, v * np.cos(0.6), v * np.sin(0.6)])
    s = dth.integrate(h, z0, dtau=0.05, order=8, t_end=500 * np.pi, regularize="ks")
    assert s.completed and s.fallback_steps == 0 and s.z.shape[1] == 6
    assert np.abs(s.energy_error).max() < 4e-15
    assert np.abs(s.z[-1] - z0).max() < 1e-8


def test_regularize_events_are_on_the_physical_state(kepler):
    s = dth.integrate(
        kepler, E099, dtau=0.05, order=8, t_end=500 * np.pi, regularize="levi-civita",
        events={"out": "q1^2 + q2^2 > 1"}, stop_on="out",
    )
    ((name, t, z),) = s.events
    assert name == "out" and s.stopped == "out"
    assert abs(np.hypot(z[0], z[1]) - 1) < 1e-13
    assert float(s.t[-1]) == t and np.array_equal(s.z[-1], z)


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        ({"method": "midpoint", "regularize": "levi-civita"}, ValueError, "applies to method \"dth\""),
        ({"regularize": "levi_civita"}, ValueError, "expected \"levi-civita\""),
        ({"regularize": "ks"}, ValueError, "use \"levi-civita\""),
        ({"regularize": "levi-civita", "centre": [0.0]}, ValueError, "centre has 1 values, expected 2"),
        ({"regularize": "levi-civita", "centre": [0.0, float("nan")]}, ValueError, "centre[1] is not finite"),
        ({"centre": [0.0, 0.0]}, TypeError, "give regularize too"),
        ({"regularize": "levi-civita", "centre": [0.5, 0.0]}, ValueError, "z0"),
    ],
)
def test_regularize_refuses_what_does_not_apply(kepler, kwargs, error, words):
    step = {"dt": 0.1} if "method" in kwargs else {"dtau": 0.05}
    kwargs = {**step, "t_end": 1.0, **kwargs}
    with pytest.raises(error) as e:
        dth.integrate(kepler, E099, **kwargs)
    assert words in str(e.value)


def test_regularize_refuses_a_hamiltonian_it_does_not_apply_to():
    spring = dth.Hamiltonian("p1^2/2 + q1^2/2")
    with pytest.raises(ValueError, match="n = 2 degrees of freedom, and this one has n = 1"):
        dth.integrate(spring, [1.0, 0.0], dtau=0.1, t_end=1.0, regularize="levi-civita")


def test_regularize_refuses_a_parabolic_start_with_the_reason():
    # E = H(z0) = 4e-16, zero to roundoff: K's Psi (proportional to E) has no sign DTH can
    # keep; it used to fail at step 1 with "a non-physical root with lambda = -1".
    h = dth.Hamiltonian("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)")
    with pytest.raises(ValueError, match="parabolic orbit"):
        dth.integrate(h, [0.5, 0.0, 0.0, np.sqrt(2.0)], dtau=0.05, t_end=1.0, regularize="levi-civita")
    # A hyperbolic orbit runs: Psi keeps its sign on it.
    s = dth.integrate(h, [0.5, 0.0, 0.0, 1.5], dtau=0.05, t_end=50.0, regularize="levi-civita")
    assert s.completed and s.energy0 == 0.25
    assert np.abs(s.energy_error).max() < 4e-15
