"""The built-in systems of the `dth` command's catalogue, one function per entry, as
`dth.Hamiltonian`s built from their texts (the same names and default parameters as in scene
files; at the catalogue's size each text computes H and its gradient to the bit as the
catalogue's compiled system does). Lattices take their size: their sums compile to loops, so
`fput_alpha(n=4096)` builds as fast as `n=32`; the N-body systems take their masses (any
number of bodies).

A Hamiltonian from here knows its system (`h.system`), and with it what its text does not
say: the orbit period (`integrate(..., orbits=...)`: kepler, harmonic_oscillator), the exact
solution (`method="exact"`: kepler, free_particle) and the central force
(`method="discrete_mechanics"`: kepler, free_particle).

>>> import dth
>>> h = dth.systems.kepler(m=0.5, k=1.0)
>>> round(h.value([0.5, 0.0, 0.0, 1.2]), 12)
-0.56
"""

from typing import Mapping, Optional, Sequence

from ._dth import Hamiltonian

__all__ = [
    "kepler",
    "harmonic_oscillator",
    "pendulum",
    "henon_heiles",
    "double_pendulum",
    "toda_chain",
    "toda_chain_10",
    "fput_alpha",
    "fput_beta",
    "toda_fixed_ends",
    "nbody_2d",
    "nbody_3d",
    "gravity_3d",
    "calogero_moser",
    "forced_oscillator",
    "free_particle",
]


def _twin(system: str, text: str, params: Optional[Mapping[str, float]] = None) -> Hamiltonian:
    """`text` as the twin of the catalogue entry `system`."""
    return Hamiltonian._catalogue_twin(system, text, dict(params) if params else None)


def kepler(m: float = 0.5, k: float = 1.0) -> Hamiltonian:
    """Planar Kepler, H = (p1^2 + p2^2)/(2 m) - k (q1^2 + q2^2)^(-1/2) (thesis: m = 1/2, k = 1)."""
    return _twin("kepler", "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)", {"m": m, "k": k})


def harmonic_oscillator(m: float = 1.0, k: float = 1.0) -> Hamiltonian:
    """H = p1^2/(2 m) + k q1^2/2."""
    return _twin("harmonic_oscillator", "p1^2/(2*m) + k*q1^2/2", {"m": m, "k": k})


def pendulum(m: float = 1.0, l: float = 1.0, g: float = 1.0) -> Hamiltonian:  # noqa: E741
    """H = p1^2/(2 m l^2) - m g l cos(q1)."""
    return _twin("pendulum", "p1^2/(2*m*l^2) - m*g*l*cos(q1)", {"m": m, "l": l, "g": g})


def henon_heiles() -> Hamiltonian:
    """H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3."""
    return _twin("henon_heiles", "(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3")


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
    return _twin("double_pendulum", text, {"m1": m1, "m2": m2, "l1": l1, "l2": l2, "g": g})


def _count(n: int, least: int, what: str) -> int:
    if isinstance(n, bool) or int(n) != n or n < least:
        raise ValueError(f"{what} must be an integer, at least {least}, not {n!r}")
    return int(n)


def toda_chain(n: int = 4) -> Hamiltonian:
    """The periodic Toda chain of n particles, H = sum p_i^2/2 + sum exp(q_i - q_{i+1}),
    q_{n+1} = q_1, written out term by term as the catalogue's `toda_chain` (n = 4) and
    `toda_chain_10`."""
    n = _count(n, 2, "n")
    kinetic = " + ".join(f"p{i}^2" for i in range(1, n + 1))
    potential = " + ".join(f"exp(q{i} - q{i % n + 1})" for i in range(1, n + 1))
    system = {4: "toda_chain", 10: "toda_chain_10"}.get(n, "toda_chain")
    return _twin(system, f"({kinetic})/2 + {potential}")


def toda_chain_10() -> Hamiltonian:
    """The periodic Toda chain of 10 particles (the catalogue's `toda_chain_10`)."""
    return toda_chain(n=10)


def toda_fixed_ends(n: int = 32) -> Hamiltonian:
    """The Toda chain of n unit masses between walls q_0 = q_{n+1} = 0."""
    return _twin(
        "toda_fixed_ends",
        f"sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, exp(q[i] - q[i+1]))"
        f" where N = {_count(n, 1, 'n')}, q[0] = q[N+1] = 0",
    )


def fput_alpha(n: int = 32, alpha: float = 0.25) -> Hamiltonian:
    """The FPUT-alpha chain of n unit masses with fixed ends q_0 = q_{n+1} = 0:
    H = sum p_i^2/2 + sum_{i=0}^{n} [d_i^2/2 + alpha d_i^3/3], d_i = q_{i+1} - q_i."""
    return _twin(
        "fput_alpha",
        f"sum(i = 1..N, p[i]^2/2)"
        f" + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)"
        f" where N = {_count(n, 1, 'n')}, q[0] = q[N+1] = 0",
        {"alpha": alpha},
    )


def fput_beta(n: int = 32, beta: float = 1.0) -> Hamiltonian:
    """The FPUT-beta chain of n unit masses with fixed ends:
    H = sum p_i^2/2 + sum_{i=0}^{n} [d_i^2/2 + beta d_i^4/4]."""
    return _twin(
        "fput_beta",
        f"sum(i = 1..N, p[i]^2/2)"
        f" + sum(i = 0..N, (q[i+1] - q[i])^2/2 + beta*(q[i+1] - q[i])^4/4)"
        f" where N = {_count(n, 1, 'n')}, q[0] = q[N+1] = 0",
        {"beta": beta},
    )


def forced_oscillator(omega0: float = 1.0, f: float = 0.1, omega: float = 1.3) -> Hamiltonian:
    """The time-dependent H = p1^2/2 + omega0^2 q1^2/2 - f q1 cos(omega t), integrated in the
    extended phase space (the time is a coordinate)."""
    return _twin(
        "forced_oscillator",
        "p1^2/2 + omega0^2*q1^2/2 - f*q1*cos(omega*t)",
        {"omega0": omega0, "f": f, "omega": omega},
    )


def _nbody(system: str, dims: int, masses: Sequence[float], g: float) -> Hamiltonian:
    """n gravitating bodies in `dims` dimensions, every pair written out (as the catalogue's
    three-body texts): body i at q_{dims (i-1) + 1} .. q_{dims i}, its momentum alike."""
    masses = [float(m) for m in masses]
    n = len(masses)
    if n < 2:
        raise ValueError(f"masses must give at least 2 bodies, not {n}")

    def coords(x: str, i: int) -> list[str]:
        return [f"{x}{dims * (i - 1) + c}" for c in range(1, dims + 1)]

    kinetic = " + ".join(
        "(" + " + ".join(f"{p}^2" for p in coords("p", i)) + f")/(2*m{i})"
        for i in range(1, n + 1)
    )
    pairs = "".join(
        f" - g*m{i}*m{j}*("
        + " + ".join(f"({a} - {b})^2" for a, b in zip(coords("q", i), coords("q", j)))
        + ")^(-1/2)"
        for i in range(1, n + 1)
        for j in range(i + 1, n + 1)
    )
    params = {f"m{i}": m for i, m in enumerate(masses, start=1)}
    params["g"] = g
    return _twin(system, kinetic + pairs, params)


def nbody_2d(masses: Sequence[float] = (1.0, 1.0, 1.0), g: float = 1.0) -> Hamiltonian:
    """len(masses) gravitating bodies in the plane, all pairs:
    H = sum |p_i|^2/(2 m_i) - g sum_{i<j} m_i m_j/|q_i - q_j|, body i at (q_{2i-1}, q_{2i});
    parameters m1..mn and g. Three unit masses are the catalogue's `nbody_2d`."""
    return _nbody("nbody_2d", 2, masses, g)


def nbody_3d(masses: Sequence[float] = (1.0, 1.0, 1.0), g: float = 1.0) -> Hamiltonian:
    """len(masses) gravitating bodies in space, all pairs, body i at
    (q_{3i-2}, q_{3i-1}, q_{3i}); parameters m1..mn and g. Three unit masses are the
    catalogue's `nbody_3d`."""
    return _nbody("nbody_3d", 3, masses, g)


def gravity_3d(n: int = 4, m: float = 1.0, g: float = 1.0) -> Hamiltonian:
    """n gravitating point masses m in space, all pairs, the pair sum written once (it
    compiles to loops, so n = 1024 builds as fast as n = 4):
    H = sum |p_i|^2/(2 m) - g m^2 sum_{i<j} 1/|q_i - q_j|, body i at (q_{3i-2}, q_{3i-1}, q_{3i})."""
    return _twin(
        "gravity_3d",
        "sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/(2*m)) - g*m^2*sum(1 <= i < j <= N,"
        " ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2))"
        f" where N = {_count(n, 2, 'n')}",
        {"m": m, "g": g},
    )


def calogero_moser(n: int = 8, g: float = 0.5) -> Hamiltonian:
    """The Calogero-Moser system of n unit masses on a line, the pair sum written once (it
    compiles to loops): H = sum p_i^2/2 + g^2 sum_{i<j} (q_i - q_j)^-2."""
    return _twin(
        "calogero_moser",
        "sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2))"
        f" where N = {_count(n, 2, 'n')}",
        {"g": g},
    )


def free_particle(m: float = 1.0) -> Hamiltonian:
    """A free particle in the plane, H = (p1^2 + p2^2)/(2 m). Its Psi is identically zero, so
    DTH cannot run on it (thesis Section 3.4): every other method can, `"exact"` and
    `"discrete_mechanics"` included."""
    return _twin("free_particle", "(p1^2 + p2^2)/(2*m)", {"m": m})
