"""dth.Hamiltonian: values and exact derivatives, flags, parameters, argument checking."""

import math

import numpy as np
import pytest

import dth
from conftest import EPS

KEPLER = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)"


def kepler_value(z, m=0.5, k=1.0):
    return (z[2] ** 2 + z[3] ** 2) / (2 * m) - k / math.sqrt(z[0] ** 2 + z[1] ** 2)


def test_version_is_the_crates():
    assert isinstance(dth.__version__, str)
    assert dth.__version__.count(".") == 2


def test_dimension_text_and_repr(kepler):
    assert kepler.dim == 4
    assert kepler.text == KEPLER
    assert "Hamiltonian(" in repr(kepler) and '"m": 0.5' in repr(kepler)


def test_value_matches_the_formula(kepler):
    rng = np.random.default_rng(1)
    for _ in range(20):
        z = rng.uniform(-2, 2, 4)
        expected = kepler_value(z)
        # Different order of the same few operations: a few eps of the terms' size.
        scale = abs(z[2] ** 2 + z[3] ** 2) + 1 / math.hypot(z[0], z[1])
        assert abs(kepler.value(z) - expected) <= 8 * EPS * scale


def test_gradient_against_central_differences(kepler):
    z = np.array([0.7, -0.4, 0.3, 1.1])
    g = kepler.gradient(z)
    assert g.shape == (4,) and g.dtype == np.float64
    h = 1e-5
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        fd = (kepler.value(z + e) - kepler.value(z - e)) / (2 * h)
        # Truncation h^2 |H'''| / 6 (|H'''| ~ 10 here) plus roundoff eps |H| / h.
        assert abs(g[i] - fd) < 1e-9


def test_hessian_is_symmetric_and_the_gradients_derivative(kepler):
    z = np.array([0.7, -0.4, 0.3, 1.1])
    m = kepler.hessian(z)
    assert m.shape == (4, 4) and m.dtype == np.float64
    assert np.array_equal(m, m.T)
    h = 1e-5
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        fd = (kepler.gradient(z + e) - kepler.gradient(z - e)) / (2 * h)
        assert np.max(np.abs(m[:, i] - fd)) < 1e-8


def test_psi_is_jgradh_hess_jgradh(kepler):
    rng = np.random.default_rng(2)
    for _ in range(10):
        z = rng.uniform(-1.5, 1.5, 4)
        g = kepler.gradient(z)
        m = kepler.hessian(z)
        jg = np.concatenate([g[2:], -g[:2]])
        expected = jg @ m @ jg
        scale = np.abs(jg) @ np.abs(m) @ np.abs(jg)
        assert abs(kepler.psi(z) - expected) <= 64 * EPS * scale


def test_flags():
    assert dth.systems.kepler().flags["separable"]
    assert not dth.systems.double_pendulum().flags["separable"]
    forced = dth.systems.forced_oscillator()
    assert forced.flags["time_dependent"]
    assert not dth.systems.kepler().flags["time_dependent"]
    assert dth.systems.kepler().flags["backend"] in ("jit", "interpreter")


def test_parameters_are_read_and_set(kepler, thesis_z0):
    assert kepler.params == {"k": 1.0, "m": 0.5}
    before = kepler.value(thesis_z0)
    kepler.set_parameter("k", 2.0)
    assert kepler.params["k"] == 2.0
    assert kepler.value(thesis_z0) == pytest.approx(before - 2.0, abs=4 * EPS * 4)


def test_an_unknown_parameter_is_a_hamiltonian_error(kepler):
    with pytest.raises(dth.HamiltonianError, match="unknown parameter `kk`"):
        kepler.set_parameter("kk", 1.0)
    with pytest.raises(dth.HamiltonianError, match="not finite"):
        kepler.set_parameter("k", float("nan"))
    with pytest.raises(dth.HamiltonianError, match="unknown parameter `x`"):
        dth.Hamiltonian("p1^2 + q1^2", params={"x": 1.0})


def test_a_syntax_error_points_at_its_token():
    text = "p1^2 + * q1^2"
    with pytest.raises(dth.HamiltonianError) as info:
        dth.Hamiltonian(text)
    e = info.value
    assert isinstance(e, ValueError)
    assert e.line == 1
    assert text[e.column - 1] == "*"
    assert e.source == text
    assert "column" in str(e)


def test_an_unknown_variable_is_named_with_its_position():
    text = "p1^2/2 + x1^2/2"
    with pytest.raises(dth.HamiltonianError, match="x1") as info:
        dth.Hamiltonian(text)
    assert text[info.value.column - 1 : info.value.column + 1] == "x1"


def test_errors_on_the_second_line_and_every_error_listed():
    text = "p1^2/2\n + y^2 + w"
    with pytest.raises(dth.HamiltonianError) as info:
        dth.Hamiltonian(text)
    e = info.value
    assert e.line == 2
    assert len(e.errors) >= 2
    for message, line, column in e.errors:
        assert isinstance(message, str) and line == 2 and column >= 1


def test_a_parameter_without_a_value_is_an_error():
    with pytest.raises(dth.HamiltonianError, match="k"):
        dth.Hamiltonian("p1^2/2 + k*q1^2/2")


def test_a_state_of_the_wrong_length_says_expected_and_found(kepler):
    with pytest.raises(ValueError, match=r"length 3, expected 4 \(q1, q2, p1, p2\)"):
        kepler.value([1.0, 0.0, 0.0])


def test_a_two_dimensional_state_is_refused(kepler):
    with pytest.raises(ValueError, match=r"shape \(2, 4\)"):
        kepler.gradient(np.zeros((2, 4)))


def test_a_state_that_is_not_numbers_is_a_type_error(kepler):
    with pytest.raises(TypeError, match="z must be a 1-D sequence of 4 floats"):
        kepler.value("abcd")


def test_lists_tuples_and_int_arrays_are_states():
    h = dth.Hamiltonian("p1^2/2 + q1^2/2")
    assert h.value([1, 2]) == h.value((1.0, 2.0)) == h.value(np.array([1, 2])) == 2.5
    assert h.value(np.array([1.0, 2.0], dtype=np.float32)) == 2.5
    # A strided view is read, not refused.
    assert h.value(np.array([1.0, 9.0, 2.0])[::2]) == 2.5


def test_derive_shows_the_derivatives(kepler):
    text = kepler.derive()
    assert "dH/dq1" in text
    assert "Psi" in text


def test_a_lattice_of_4096_sites_builds_with_its_pattern():
    chain = dth.systems.fput_alpha(n=4096)
    assert chain.dim == 8192
    assert chain.flags["structured_newton"]
    rows, cols = chain.hessian_pattern()
    assert rows.shape == cols.shape and len(rows) < 8192 * 8
    z = np.zeros(8192)
    z[0] = 0.1
    m = chain.hessian(z)
    nonzero = np.argwhere(m != 0)
    allowed = set(zip(rows.tolist(), cols.tolist()))
    for i, j in nonzero:
        assert (min(i, j), max(i, j)) in allowed


def test_the_sparse_hessian_is_the_dense_one_on_its_pattern():
    chain = dth.systems.fput_beta(n=24)
    z = np.random.default_rng(4).uniform(-0.5, 0.5, chain.dim)
    rows, cols, values = chain.hessian(z, sparse=True)
    assert values.dtype == np.float64 and rows.shape == cols.shape == values.shape
    pattern_rows, pattern_cols = chain.hessian_pattern()
    assert np.array_equal(rows, pattern_rows) and np.array_equal(cols, pattern_cols)
    assert np.all(rows <= cols)
    dense = chain.hessian(z)
    # The same compiled derivatives, written two ways: equal to the bit.
    assert np.array_equal(dense[rows, cols], values)
    # And nothing outside the pattern (or its mirror).
    rebuilt = np.zeros_like(dense)
    rebuilt[rows, cols] = values
    rebuilt[cols, rows] = values
    assert np.array_equal(rebuilt, dense)


def test_a_sparse_hessian_without_a_pattern_is_refused(kepler, thesis_z0):
    assert kepler.hessian_pattern() is None
    with pytest.raises(ValueError, match="sparse=True: this Hamiltonian has no Hessian pattern"):
        kepler.hessian(thesis_z0, sparse=True)
