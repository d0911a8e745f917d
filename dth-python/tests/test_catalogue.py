"""dth.systems against the `dth` command's catalogue: one twin per entry, its text equal to
the catalogue's compiled system to the bit, and what the system adds to its text: the orbit
period (orbits=), the exact solution (method="exact") and the central force
(method="discrete_mechanics")."""

import numpy as np
import pytest

import dth
from dth import _dth

CATALOGUE = _dth._catalogue()
NAMES = [entry["name"] for entry in CATALOGUE]
THESIS = np.array([0.5, 0.0, 0.0, 1.2])


def twin(entry):
    return getattr(dth.systems, entry["name"])()


def test_every_catalogue_entry_has_its_twin_and_nothing_else_is_exported():
    assert len(NAMES) >= 14
    assert sorted(dth.systems.__all__) == sorted(NAMES)


@pytest.mark.parametrize("entry", CATALOGUE, ids=NAMES)
def test_the_twin_has_the_entrys_size_parameters_and_defaults(entry):
    h = twin(entry)
    extended = 2 if entry["time_dependent"] else 0
    assert h.dim == 2 * entry["n"] + extended
    assert h.params == entry["params"]
    assert h.system == entry["name"]
    assert h.flags["time_dependent"] == entry["time_dependent"]
    assert h.flags["psi_identically_zero"] == (not entry["dth"])


@pytest.mark.parametrize("entry", CATALOGUE, ids=NAMES)
def test_the_twins_text_computes_the_catalogues_value_and_gradient_to_the_bit(entry):
    h = twin(entry)
    rng = np.random.default_rng(sum(map(ord, entry["name"])))
    for _ in range(3):
        # Generic states: bodies apart, angles and momenta of order one.
        z = rng.uniform(-1.0, 1.0, h.dim)
        value, gradient = _dth._catalogue_evaluate(entry["name"], {}, z.tolist())
        assert h.value(z) == value
        assert np.array_equal(h.gradient(z), np.array(gradient))


def test_the_twins_follow_the_catalogue_at_other_parameters():
    h = dth.systems.kepler(m=0.7, k=1.3)
    value, gradient = _dth._catalogue_evaluate("kepler", {"m": 0.7, "k": 1.3}, [0.4, 0.3, -0.2, 1.1])
    assert h.value([0.4, 0.3, -0.2, 1.1]) == value
    bodies = dth.systems.nbody_3d(masses=(1.0, 2.0, 0.5), g=0.9)
    z = np.random.default_rng(3).uniform(-1, 1, 18)
    params = {"m1": 1.0, "m2": 2.0, "m3": 0.5, "g": 0.9}
    value, gradient = _dth._catalogue_evaluate("nbody_3d", params, z.tolist())
    assert bodies.value(z) == value and np.array_equal(bodies.gradient(z), gradient)


@pytest.mark.parametrize("make, dims", [(dth.systems.nbody_2d, 2), (dth.systems.nbody_3d, 3)])
def test_n_bodies_of_any_number_are_newtonian_gravity(make, dims):
    masses = [1.0, 0.5, 2.0, 0.25, 1.5]
    h = make(masses=masses, g=0.8)
    n = len(masses)
    assert h.dim == 2 * dims * n and h.system is None  # not the catalogue's three bodies
    z = np.random.default_rng(5).uniform(-1, 1, h.dim)
    q = z[: dims * n].reshape(n, dims)
    p = z[dims * n :].reshape(n, dims)
    kinetic = sum(p[i] @ p[i] / (2 * masses[i]) for i in range(n))
    potential = -0.8 * sum(
        masses[i] * masses[j] / np.linalg.norm(q[i] - q[j]) for i in range(n) for j in range(i + 1, n)
    )
    # Sums of 15 terms of size ~10: a few eps of the largest partial sum.
    assert abs(h.value(z) - (kinetic + potential)) <= 64 * np.finfo(float).eps * (
        abs(kinetic) + abs(potential)
    )


def test_sizes_are_checked():
    with pytest.raises(ValueError, match="masses must give at least 2 bodies"):
        dth.systems.nbody_2d(masses=[1.0])
    with pytest.raises(ValueError, match="n must be an integer, at least 2"):
        dth.systems.toda_chain(n=1)
    with pytest.raises(ValueError, match="n must be an integer"):
        dth.systems.fput_alpha(n=2.5)


def test_a_lattice_of_another_size_is_a_plain_text():
    assert dth.systems.fput_alpha(n=32).system == "fput_alpha"
    assert dth.systems.fput_alpha(n=64).system is None
    assert dth.systems.toda_chain(n=10).system == "toda_chain_10"



@pytest.mark.parametrize("entry", CATALOGUE, ids=NAMES)
def test_what_the_catalogue_offers_python_offers(entry):
    """orbits=, "exact" and "discrete_mechanics" work exactly where the catalogue says."""
    h = twin(entry)
    z0 = THESIS if h.dim == 4 and not entry["time_dependent"] else np.full(h.dim, 0.1)
    if entry["time_dependent"]:
        z0 = [0.1, 0.0]
    asks = [
        ("has_period", dict(method="rk4", dt=0.05, orbits=0.5), "orbit period"),
        ("has_exact", dict(method="exact", dt=0.05, steps=3), 'method="exact"'),
        ("central_force", dict(method="discrete_mechanics", dt=0.05, steps=3), "central force"),
    ]
    for flag, kwargs, refusal in asks:
        if entry[flag]:
            s = dth.integrate(h, z0, **kwargs)
            assert s.completed, (flag, s.failure)
        else:
            with pytest.raises(ValueError, match=refusal) as info:
                dth.integrate(h, z0, **kwargs)
            assert f"dth.systems.{entry['name']} has none" in str(info.value)
