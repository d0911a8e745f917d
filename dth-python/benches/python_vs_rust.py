"""The Python package against the Rust library and the `dth` command, measured side by side.

1. 10^6 DTH steps of the thesis's Kepler (text, dtau = 0.06277) from Python
   (`dth.integrate`) and through the Rust library (`dth::solve` on `dth::runtime::Fixed<4>`,
   the example `python_baseline` of dth-examples): the same run, the final states compared.
2. A Henon-Heiles ensemble of about 1,000 members (E = 1/8 shell, DTH to t = 200) from
   Python (`dth.ensemble`) and as a scene through `dth run` (whole command, files written),
   the scene's system given as the same text, and as the catalogue's compiled type.
3. Context: scipy's `solve_ivp(DOP853)` on Kepler (10 orbits, e = 0.44) at the accuracy DTH
   of order 8 reaches, both errors measured against Kepler's equation.

Needs the package built in release (`pip install ./dth-python`, or
`maturin develop --release -m dth-python/Cargo.toml` in a virtual environment) and scipy
(installed here if missing). Run from the repository root:
`python dth-python/benches/python_vs_rust.py`.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import dth

ROOT = Path(__file__).resolve().parents[2]
REPEATS = 3


def cargo(*args: str) -> None:
    subprocess.run(["cargo", *args], cwd=ROOT, check=True)


def target_dir() -> Path:
    return Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))


def kepler_steps(steps: int) -> None:
    cargo("build", "--release", "-q", "-p", "dth-examples", "--example", "python_baseline")
    baseline = target_dir() / "release" / "examples" / "python_baseline"
    h = dth.systems.kepler()
    z0 = [0.5, 0.0, 0.0, 1.2]
    py_times, rust_times = [], []
    for _ in range(REPEATS):
        started = time.perf_counter()
        s = dth.integrate(h, z0, dtau=0.06277, steps=steps, every=steps)
        py_times.append(time.perf_counter() - started)
        out = subprocess.run([baseline, str(steps)], capture_output=True, text=True, check=True)
        words = out.stdout.split()
        rust_times.append(float(words[1]))
        rust_final = np.array([float(w) for w in words[5:9]])
    assert s.completed and s.steps == steps
    same = np.array_equal(s.z[-1], rust_final)
    py, rust = min(py_times), min(rust_times)
    print(f"Kepler, {steps} DTH steps: Python {py:.3f} s, Rust library {rust:.3f} s, "
          f"Python / Rust = {py / rust:.3f} (best of {REPEATS}); same final state: {same}")


HH_SCENE = """
title = "Henon-Heiles ensemble for the Python comparison"
[system]
SYSTEM
[initial]
q = [0.0, 0.0]
p = [0.0, 0.0]
[ensemble]
kind = "grid"
x = "q2"
x_range = [-0.42, 0.58]
x_count = 37
y = "p2"
y_range = [-0.48, 0.48]
y_count = 37
energy = 0.125
solve = "p1"
[[method]]
kind = "dth"
dtau = 0.1
[duration]
time = 200.0
"""


# The scene's system: the catalogue's compiled type, or the text Python compiles.
SYSTEMS = {
    "catalogue": 'name = "henon_heiles"',
    "text": 'hamiltonian = "(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3"',
}


def ensemble(system: str) -> None:
    cargo("build", "--release", "-q", "-p", "dth-examples", "--bin", "dth")
    binary = target_dir() / "release" / "dth"
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "hh.toml"
        scene.write_text(HH_SCENE.replace("SYSTEM", SYSTEMS[system]))
        cli_times = []
        for i in range(REPEATS):
            out = Path(tmp) / f"run{i}"
            started = time.perf_counter()
            subprocess.run([binary, "run", scene, "--out", out], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            cli_times.append(time.perf_counter() - started)
        table = dth.scenes._read_csv(out / "ensemble.csv")
    ran = ~np.isnan(table["start_p1"])
    z0s = np.column_stack([table[f"start_{c}"][ran] for c in ("q1", "q2", "p1", "p2")])
    h = dth.systems.henon_heiles()
    py_times = []
    for _ in range(REPEATS):
        started = time.perf_counter()
        e = dth.ensemble(h, z0s, dtau=0.1, t_end=200.0)
        py_times.append(time.perf_counter() - started)
    ends = np.column_stack([table[f"end_{c}"][ran] for c in ("q1", "q2", "p1", "p2")])
    agree = np.max(np.abs(ends - e.final))
    py, cli = min(py_times), min(cli_times)
    print(f"Henon-Heiles ensemble, {len(z0s)} members to t = 200 on {os.cpu_count()} cores: "
          f"Python {py:.3f} s, dth run ({system} system) {cli:.3f} s, "
          f"Python / dth run = {py / cli:.3f} "
          f"(best of {REPEATS}); final states agree to {agree:.1e}")


def kepler_exact(t: float, z0: np.ndarray) -> np.ndarray:
    """The thesis's Kepler (m = 1/2, k = 1, so mu = k/m = 2) from pericentre z0 at time t."""
    mu = 2.0
    r0, v0 = z0[0], z0[3] / 0.5
    a = 1.0 / (2.0 / r0 - v0**2 / mu)
    e = 1.0 - r0 / a
    n = np.sqrt(mu / a**3)
    mean = n * t
    ecc = mean
    for _ in range(50):
        ecc -= (ecc - e * np.sin(ecc) - mean) / (1 - e * np.cos(ecc))
    q1 = a * (np.cos(ecc) - e)
    q2 = a * np.sqrt(1 - e**2) * np.sin(ecc)
    de = n / (1 - e * np.cos(ecc))
    v1 = -a * np.sin(ecc) * de
    v2 = a * np.sqrt(1 - e**2) * np.cos(ecc) * de
    return np.array([q1, q2, 0.5 * v1, 0.5 * v2])


def context_dop853() -> None:
    try:
        from scipy.integrate import solve_ivp
    except ImportError:
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", "scipy"], check=True)
        from scipy.integrate import solve_ivp
    h = dth.systems.kepler()
    z0 = np.array([0.5, 0.0, 0.0, 1.2])
    t_end = 37.4833
    exact = kepler_exact(t_end, z0)
    started = time.perf_counter()
    s = dth.integrate(h, z0, dtau=0.1, order=8, t_end=t_end, every=10**9)
    dth_time = time.perf_counter() - started
    dth_error = np.max(np.abs(s.z[-1] - exact))

    def rhs(_t: float, z: np.ndarray) -> np.ndarray:
        r3 = (z[0] ** 2 + z[1] ** 2) ** 1.5
        return np.array([2 * z[2], 2 * z[3], -z[0] / r3, -z[1] / r3])

    for tol in (1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13):
        started = time.perf_counter()
        sol = solve_ivp(rhs, (0, t_end), z0, method="DOP853", rtol=tol, atol=tol)
        scipy_time = time.perf_counter() - started
        scipy_error = np.max(np.abs(sol.y[:, -1] - exact))
        if scipy_error <= dth_error:
            break
    print(f"Kepler e = 0.44, 10 orbits: DTH order 8 (dtau = 0.1, from Python) error "
          f"{dth_error:.1e} in {dth_time * 1e3:.1f} ms; scipy DOP853 (rtol = atol = {tol:g}) "
          f"error {scipy_error:.1e} in {scipy_time * 1e3:.1f} ms, "
          f"{scipy_time / dth_time:.0f}x DTH's time")


if __name__ == "__main__":
    kepler_steps(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
    ensemble("text")
    ensemble("catalogue")
    context_dop853()
