"""DTH: Discrete-Time Hamiltonian dynamics from Python.

Write a Hamiltonian as text, get its exact derivatives compiled to machine code, and
integrate it with DTH (energy conserved to roundoff at every midpoint) or one of its peers,
numpy arrays in and out. The whole integration runs in Rust: no Python per step.

>>> import dth
>>> kepler = dth.systems.kepler()            # H = (p1^2 + p2^2)/(2m) - k/|q|, m = 1/2, k = 1
>>> s = dth.integrate(kepler, [0.5, 0.0, 0.0, 1.2], dtau=0.06277, steps=1000)
>>> s.z.shape
(1001, 4)
>>> bool(abs(s.energy_error).max() < 1e-14)
True

Contents: `Hamiltonian` (text -> compiled H, gradient, Hessian, Psi), `integrate` (one
call, every method), `Solution` (its result), `ensemble` (many initial states or parameter
values on every core, MEGNO on demand) and `Ensemble`, `systems` (the built-in systems as
texts),
`run_scene` (a scene file run as `dth run` does: its summary and arrays), `HamiltonianError`
(a `ValueError` with `.line` and `.column`), `IntegrationError` and `SceneError`.
"""

from ._dth import (
    METHODS,
    Ensemble,
    Hamiltonian,
    HamiltonianError,
    IntegrationError,
    SceneError,
    Solution,
    __version__,
    ensemble,
    integrate,
)
from . import systems
from .scenes import SceneRun, run_scene

__all__ = [
    "METHODS",
    "Ensemble",
    "Hamiltonian",
    "HamiltonianError",
    "IntegrationError",
    "SceneError",
    "SceneRun",
    "Solution",
    "__version__",
    "ensemble",
    "integrate",
    "run_scene",
    "systems",
]
