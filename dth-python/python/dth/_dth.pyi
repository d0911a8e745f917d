"""Type stubs of the extension module `dth._dth` (see `dth.__doc__`)."""

from typing import Literal, Mapping, Optional, Sequence, Tuple, Union, overload

import os

import numpy as np
import numpy.typing as npt

__version__: str
METHODS: list[str]

State = Union[npt.ArrayLike, Sequence[float]]

class HamiltonianError(ValueError):
    line: Optional[int]
    column: Optional[int]
    errors: list[tuple[str, Optional[int], Optional[int]]]
    source: str

class IntegrationError(RuntimeError):
    kind: Optional[str]
    solution: "Solution"

class Hamiltonian:
    def __init__(self, text: str, params: Optional[Mapping[str, float]] = None) -> None: ...
    @staticmethod
    def _catalogue_twin(
        system: str, text: str, params: Optional[Mapping[str, float]] = None
    ) -> "Hamiltonian": ...
    @property
    def system(self) -> Optional[str]: ...
    @property
    def dim(self) -> int: ...
    @property
    def text(self) -> str: ...
    @property
    def flags(self) -> dict[str, Union[bool, str]]: ...
    @property
    def params(self) -> dict[str, float]: ...
    @property
    def warnings(self) -> list[str]: ...
    def set_parameter(self, name: str, value: float) -> None: ...
    def value(self, z: State) -> float: ...
    def gradient(self, z: State) -> npt.NDArray[np.float64]: ...
    @overload
    def hessian(self, z: State, sparse: Literal[False] = False) -> npt.NDArray[np.float64]: ...
    @overload
    def hessian(
        self, z: State, sparse: Literal[True]
    ) -> tuple[npt.NDArray[np.uintp], npt.NDArray[np.uintp], npt.NDArray[np.float64]]: ...
    def hessian_pattern(
        self,
    ) -> Optional[tuple[npt.NDArray[np.uintp], npt.NDArray[np.uintp]]]: ...
    def psi(self, z: State) -> float: ...
    def derive(self) -> str: ...

class Solution:
    @property
    def method(self) -> str: ...
    @property
    def t(self) -> npt.NDArray[np.float64]: ...
    @property
    def z(self) -> npt.NDArray[np.float64]: ...
    @property
    def k(self) -> npt.NDArray[np.uintp]: ...
    @property
    def kinds(self) -> list[str]: ...
    @property
    def energy_error(self) -> npt.NDArray[np.float64]: ...
    @property
    def energy0(self) -> float: ...
    @property
    def lam(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def vertices(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def vertex_t(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def psi(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def steps(self) -> int: ...
    @property
    def fallback_steps(self) -> int: ...
    @property
    def newton_iterations(self) -> int: ...
    @property
    def failure(self) -> Optional[str]: ...
    @property
    def failure_kind(self) -> Optional[str]: ...
    @property
    def completed(self) -> bool: ...
    @property
    def events(self) -> list[tuple[str, float, npt.NDArray[np.float64]]]: ...
    @property
    def stopped(self) -> Optional[str]: ...
    def __len__(self) -> int: ...

def integrate(
    h: Hamiltonian,
    z0: State,
    method: str = "dth",
    *,
    dtau: Optional[float] = None,
    dt: Optional[float] = None,
    order: Optional[int] = None,
    robust: Optional[bool] = None,
    lambda0: Optional[float] = None,
    steps: Optional[int] = None,
    t_end: Optional[float] = None,
    orbits: Optional[float] = None,
    t0: float = 0.0,
    every: Optional[int] = None,
    save_at: Optional[Sequence[float]] = None,
    max_steps: Optional[int] = None,
    energy_errors: bool = True,
    raise_on_failure: bool = False,
    events: Optional[Mapping[str, str]] = None,
    stop_on: Union[str, Sequence[str], None] = None,
    regularize: Optional[str] = None,
    centre: Optional[Sequence[float]] = None,
    double_double: bool = False,
) -> Solution: ...

class Ensemble:
    @property
    def final(self) -> npt.NDArray[np.float64]: ...
    @property
    def t_end(self) -> npt.NDArray[np.float64]: ...
    @property
    def energy_error(self) -> npt.NDArray[np.float64]: ...
    @property
    def steps(self) -> npt.NDArray[np.uintp]: ...
    @property
    def fallback_steps(self) -> npt.NDArray[np.uintp]: ...
    @property
    def failure(self) -> list[Optional[str]]: ...
    @property
    def failed(self) -> int: ...
    @property
    def megno(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def lyapunov(self) -> Optional[npt.NDArray[np.float64]]: ...
    def __len__(self) -> int: ...

def ensemble(
    h: Hamiltonian,
    z0s: npt.ArrayLike,
    method: str = "dth",
    *,
    dtau: Optional[float] = None,
    dt: Optional[float] = None,
    order: Optional[int] = None,
    robust: Optional[bool] = None,
    lambda0: Optional[float] = None,
    steps: Optional[int] = None,
    t_end: Optional[float] = None,
    orbits: Optional[float] = None,
    t0: float = 0.0,
    max_steps: Optional[int] = None,
    threads: Optional[int] = None,
    params: Optional[Mapping[str, npt.ArrayLike]] = None,
    megno: bool = False,
    lyapunov: bool = False,
    regularize: Optional[str] = None,
    centre: Optional[Sequence[float]] = None,
) -> Ensemble: ...

class SceneError(ValueError): ...

def _catalogue() -> list[dict[str, object]]: ...
def _catalogue_evaluate(
    name: str, params: Mapping[str, float], z: Sequence[float]
) -> tuple[float, list[float]]: ...
def run_scene_into(
    text: str, file: str, out: str, threads: Optional[int] = None
) -> Tuple[bool, Union[str, "os.PathLike[str]"]]: ...
