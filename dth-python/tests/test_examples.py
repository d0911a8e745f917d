"""The example scripts run (shortened where they integrate long) and type-check with the
package's stubs under `mypy --strict`."""

import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "examples"


@pytest.mark.parametrize(
    "script, args, expected",
    [
        ("kepler_energy.py", [], "dth "),
        ("fput_modes.py", ["-", "1000"], "max |H - H0|"),
        ("henon_heiles_section.py", ["-", "200"], "crossings of q1 = 0"),
    ],
)
def test_the_example_runs(script, args, expected):
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert expected in done.stdout


def test_the_examples_type_check_strictly():
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--strict",
            "--config-file",
            str(HERE.parent / "pyproject.toml"),
            "--cache-dir",
            str(HERE.parent / ".mypy_cache"),
            str(EXAMPLES),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
