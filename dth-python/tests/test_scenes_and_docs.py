"""dth.run_scene, and the examples in the docstrings (they are run here)."""

import doctest
from pathlib import Path

import numpy as np
import pytest

import dth
from conftest import kepler_scene_trajectory

SCENES = Path(__file__).resolve().parents[2] / "dth-examples" / "scenes"


def test_a_shipped_scene_runs_from_its_path():
    run = dth.run_scene(SCENES / "pendulum.toml")
    assert run.completed and run.out is None
    labels = [m["label"] for m in run.summary["methods"]]
    assert labels == ["dth", "midpoint", "stormer_verlet"]
    for m in run.summary["methods"]:
        assert m["failure"] is None and m["t_end"] == 200.0
    energy = run.arrays["dth_energy"]
    assert energy["t"][0] == 0.0
    # DTH's midpoints keep the energy to roundoff (|H| <= 1 here).
    assert np.max(np.abs(energy["energy_deviation"])) <= 4 * np.finfo(float).eps


def test_the_output_folder_is_written_when_asked(tmp_path):
    out = tmp_path / "pendulum"
    run = dth.run_scene(SCENES / "pendulum.toml", out)
    assert run.out == out
    assert (out / "summary.json").is_file() and (out / "index.html").is_file()


KEPLER_E09 = """
title = "kepler e = 0.9"
[system]
name = "kepler"
[initial]
q = [0.5, 0.0]
p = [0.0, 1.3784048752090221]
[[method]]
kind = "dth"
dtau = 0.01
{robust}
[duration]
time = 2.0
"""


def test_an_incomplete_rerun_goes_beside_a_complete_result(tmp_path):
    # Plain DTH breaks down near pericentre at e = 0.9 (Psi changes sign); robust DTH
    # completes. The failing rerun must not replace the complete result, and what
    # run_scene returns is the folder it wrote.
    out = tmp_path / "kepler"
    complete = dth.run_scene(KEPLER_E09.format(robust="robust = true"), out)
    assert complete.completed and complete.out == out
    before = (out / "summary.json").read_bytes()
    failed = dth.run_scene(KEPLER_E09.format(robust=""), out)
    assert not failed.completed
    assert failed.out is not None and failed.out != out and failed.out.is_dir()
    assert failed.summary["methods"][0]["failure"] is not None
    assert (out / "summary.json").read_bytes() == before


def test_a_bad_scene_is_a_scene_error_with_its_position():
    text = '[system]\nname = "pendulum"\n[[method]]\nkind = "dht"\ndtau = 0.1\n'
    with pytest.raises(dth.SceneError, match="dht") as info:
        dth.run_scene(text)
    assert isinstance(info.value, ValueError)
    assert "<scene>:4" in str(info.value)


def test_a_scene_that_is_neither_path_nor_text_is_a_type_error():
    with pytest.raises(TypeError, match="path or TOML text"):
        dth.run_scene(42)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "module",
    [dth, dth.systems, dth.scenes],
    ids=lambda m: m.__name__,
)
def test_the_docstring_examples_run(module):
    result = doctest.testmod(module, raise_on_error=False, verbose=False)
    assert result.attempted > 0
    assert result.failed == 0


def test_the_extensions_docstring_examples_run():
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner()
    attempted = 0
    for obj in (dth.Hamiltonian, dth.integrate, dth.ensemble):
        for test in finder.find(obj, obj.__name__, globs={"dth": dth}):
            runner.run(test)
            attempted += len(test.examples)
    assert attempted > 0
    assert runner.failures == 0


def test_help_shows_complete_docstrings():
    doc = dth.integrate.__doc__
    assert doc is not None
    for argument in ("dtau", "dt", "order", "robust", "steps", "t_end", "orbits", "every",
                     "save_at", "raise_on_failure"):
        assert f"{argument}:" in doc
    for method in dth.METHODS:
        assert f'"{method}"' in doc
    doc = dth.ensemble.__doc__
    assert doc is not None
    for argument in ("z0s", "params", "orbits", "threads", "megno, lyapunov"):
        assert f"{argument}:" in doc
    assert "sparse=True" in (dth.Hamiltonian.hessian.__doc__ or "")
    assert dth.Hamiltonian.__doc__ and "HamiltonianError" in dth.Hamiltonian.__doc__


def test_a_text_kepler_matches_the_built_in_to_the_bit():
    # The scene runs the catalogue's `kepler` (a compiled hamiltonian! type at Const<4>);
    # Python integrates the same text compiled at run time, viewed at Const<4> as well. The
    # JIT performs the macro's operations in its order and the stepper's linear algebra is
    # the same, so every DTH midpoint is the same to the last bit (the CSV keeps every digit).
    _, built_in = kepler_scene_trajectory("steps = 300")
    s = dth.integrate(dth.systems.kepler(), [0.5, 0.0, 0.0, 1.2], dtau=0.06277, steps=300)
    assert built_in.shape == s.z.shape
    assert np.array_equal(built_in, s.z)
