"""`dth.run_scene`: run a scene file (or its TOML text) as `dth run` does, and get its
summary and the arrays it computed back in Python."""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

from ._dth import run_scene_into

__all__ = ["SceneRun", "run_scene"]


@dataclass
class SceneRun:
    """What a scene run produced.

    Attributes:
        summary: `summary.json` as a dict (per method: steps, t_end, failure, energy
            deviations, fallback steps, ...).
        arrays: every CSV file the run wrote, by file stem (`"dth_energy"`,
            `"rk4_poincare1"`, ...), each a dict of column name -> array (float, or str for a column of names).
        completed: every method reached its end (a failed method's outputs are kept and
            `summary["methods"][i]["failure"]` says what stopped it).
        out: the output folder, or None when the run went to a temporary folder (removed).
    """

    summary: dict[str, Any]
    arrays: dict[str, dict[str, npt.NDArray[Any]]] = field(default_factory=dict)
    completed: bool = True
    out: Optional[Path] = None


def _number(cell: str) -> float:
    return float(cell) if cell else np.nan


def _read_csv(path: Path) -> dict[str, npt.NDArray[Any]]:
    """A CSV file by column: numbers as float arrays (an empty cell, or the missing end of a
    short row, is NaN: a DTH trajectory's last, shortened step has no right vertex), any
    other column (method names in an ensemble's table) as an array of str."""
    with path.open() as f:
        header = f.readline().strip().split(",")
        rows = [line.rstrip("\n").split(",") for line in f if line.strip()]
    columns: dict[str, npt.NDArray[Any]] = {}
    for j, name in enumerate(header):
        cells = [row[j] if j < len(row) else "" for row in rows]
        try:
            columns[name] = np.array([_number(c) for c in cells], dtype=np.float64)
        except ValueError:
            columns[name] = np.array(cells, dtype=str)
    return columns


def _scene_text(scene: Union[str, os.PathLike[str]]) -> tuple[str, str]:
    """(text, name for messages) of a path or of TOML text."""
    if isinstance(scene, os.PathLike) or (
        isinstance(scene, str) and "\n" not in scene and scene.endswith(".toml")
    ):
        path = Path(scene)
        return path.read_text(), str(path)
    if not isinstance(scene, str):
        raise TypeError(f"scene must be a path or TOML text, not {type(scene).__name__}")
    return scene, "<scene>"


def _collect(folder: Path, completed: bool, out: Optional[Path]) -> SceneRun:
    summary = json.loads((folder / "summary.json").read_text())
    arrays = {p.stem: _read_csv(p) for p in sorted(folder.glob("*.csv"))}
    return SceneRun(summary=summary, arrays=arrays, completed=completed, out=out)


def run_scene(
    scene: Union[str, os.PathLike[str]],
    out: Union[str, os.PathLike[str], None] = None,
    *,
    threads: Optional[int] = None,
) -> SceneRun:
    """Run a scene as the `dth run` command does and return its summary and arrays.

    Args:
        scene: a path to a scene file (`.toml`) or the scene's TOML text.
        out: the output folder to write (figures, CSV files, `index.html`, `summary.json`);
            a rerun replaces only what dth wrote there, and a run that does not complete
            goes beside a complete earlier result (`out.incomplete`, given as
            `SceneRun.out`); by default the run goes to a temporary
            folder, read back and removed.
        threads: threads for an ensemble scene (default: every core).

    Raises:
        SceneError: the scene is invalid (every problem listed, at file:line:column) or
            cannot run; nothing was written.
        KeyboardInterrupt: Ctrl-C during the run.

    >>> import dth
    >>> run = dth.run_scene('''
    ... title = "oscillator"
    ... [system]
    ... name = "harmonic_oscillator"
    ... [initial]
    ... q = [1.0]
    ... p = [0.0]
    ... [[method]]
    ... kind = "dth"
    ... dtau = 0.1
    ... [duration]
    ... time = 10.0
    ... [[effect]]
    ... kind = "energy_deviation"
    ... ''')
    >>> run.summary["methods"][0]["t_end"]
    10.0
    >>> float(abs(run.arrays["dth_energy"]["energy_deviation"]).max()) < 1e-15
    True
    """
    text, name = _scene_text(scene)
    if out is not None:
        # An incomplete run beside a complete earlier result goes to `out.incomplete`.
        completed, written = run_scene_into(text, name, str(Path(out)), threads)
        return _collect(Path(written), completed, Path(written))
    with tempfile.TemporaryDirectory(prefix="dth-scene-") as tmp:
        completed, written = run_scene_into(text, name, str(Path(tmp) / "run"), threads)
        return _collect(Path(written), completed, None)
