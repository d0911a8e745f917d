"""The built-in systems of the `dth` command's catalogue, as `dth.Hamiltonian`s built from
their texts (the same names and default parameters as in scene files). Lattices take their
size: their sums compile to loops, so `fput_alpha(n=4096)` builds as fast as `n=32`.

>>> import dth
>>> h = dth.systems.kepler(m=0.5, k=1.0)
>>> round(h.value([0.5, 0.0, 0.0, 1.2]), 12)
-0.56
"""

from ._dth import Hamiltonian

__all__ = [
    "kepler",
    "harmonic_oscillator",
    "pendulum",
    "henon_heiles",
    "double_pendulum",
    "toda_chain",
    "toda_fixed_ends",
    "fput_alpha",
    "fput_beta",
    "forced_oscillator",
]


def kepler(m: float = 0.5, k: float = 1.0) -> Hamiltonian:
    """Planar Kepler, H = (p1^2 + p2^2)/(2 m) - k (q1^2 + q2^2)^(-1/2) (thesis: m = 1/2, k = 1)."""
    return Hamiltonian("(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)", params={"m": m, "k": k})


def harmonic_oscillator(m: float = 1.0, k: float = 1.0) -> Hamiltonian:
    """H = p1^2/(2 m) + k q1^2/2."""
    return Hamiltonian("p1^2/(2*m) + k*q1^2/2", params={"m": m, "k": k})


def pendulum(m: float = 1.0, l: float = 1.0, g: float = 1.0) -> Hamiltonian:  # noqa: E741
    """H = p1^2/(2 m l^2) - m g l cos(q1)."""
    return Hamiltonian("p1^2/(2*m*l^2) - m*g*l*cos(q1)", params={"m": m, "l": l, "g": g})


def henon_heiles() -> Hamiltonian:
    """H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3."""
    return Hamiltonian("(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3")


def double_pendulum(
    m1: float = 1.0, m2: float = 1.0, l1: float = 1.0, l2: float = 1.0, g: float = 1.0
) -> Hamiltonian:
    """The planar double pendulum in canonical coordinates: angles q1, q2 from the downward
    vertical, their conjugate momenta p1, p2."""
    text = (
        "(m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))"
        " / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))"
        " - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)"
    )
    return Hamiltonian(text, params={"m1": m1, "m2": m2, "l1": l1, "l2": l2, "g": g})


def toda_chain(n: int = 4) -> Hamiltonian:
    """The periodic Toda chain of n particles, H = sum p_i^2/2 + sum exp(q_i - q_{i+1}),
    q_{n+1} = q_1."""
    return Hamiltonian(
        f"sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = {int(n)}, q[N+1] = q[1]"
    )


def toda_fixed_ends(n: int = 32) -> Hamiltonian:
    """The Toda chain of n unit masses between walls q_0 = q_{n+1} = 0."""
    return Hamiltonian(
        f"sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, exp(q[i] - q[i+1]))"
        f" where N = {int(n)}, q[0] = q[N+1] = 0"
    )


def fput_alpha(n: int = 32, alpha: float = 0.25) -> Hamiltonian:
    """The FPUT-alpha chain of n unit masses with fixed ends q_0 = q_{n+1} = 0:
    H = sum p_i^2/2 + sum_{i=0}^{n} [d_i^2/2 + alpha d_i^3/3], d_i = q_{i+1} - q_i."""
    return Hamiltonian(
        f"sum(i = 1..N, p[i]^2/2)"
        f" + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)"
        f" where N = {int(n)}, q[0] = q[N+1] = 0",
        params={"alpha": alpha},
    )


def fput_beta(n: int = 32, beta: float = 1.0) -> Hamiltonian:
    """The FPUT-beta chain of n unit masses with fixed ends:
    H = sum p_i^2/2 + sum_{i=0}^{n} [d_i^2/2 + beta d_i^4/4]."""
    return Hamiltonian(
        f"sum(i = 1..N, p[i]^2/2)"
        f" + sum(i = 0..N, (q[i+1] - q[i])^2/2 + beta*(q[i+1] - q[i])^4/4)"
        f" where N = {int(n)}, q[0] = q[N+1] = 0",
        params={"beta": beta},
    )


def forced_oscillator(omega0: float = 1.0, f: float = 0.1, omega: float = 1.3) -> Hamiltonian:
    """The time-dependent H = p1^2/2 + omega0^2 q1^2/2 - f q1 cos(omega t), integrated in the
    extended phase space (the time is a coordinate)."""
    return Hamiltonian(
        "p1^2/2 + omega0^2*q1^2/2 - f*q1*cos(omega*t)",
        params={"omega0": omega0, "f": f, "omega": omega},
    )
