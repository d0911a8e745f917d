"""The thesis's Kepler comparison: DTH keeps the energy at its midpoints to roundoff, the
implicit midpoint and trapezoidal rules at the same step let it oscillate.

Run: python kepler_energy.py [figure.png]   (the figure needs matplotlib)
"""

from __future__ import annotations

import sys

import numpy as np

import dth


def main(figure: str | None) -> None:
    kepler = dth.systems.kepler()  # (p1^2 + p2^2)/(2m) - k/|q|, m = 1/2, k = 1
    z0 = np.array([0.5, 0.0, 0.0, 1.2])  # pericentre 0.5, e = 0.44
    t_end = 37.4833  # ten periods
    runs = {
        "dth": dth.integrate(kepler, z0, dtau=0.06277, t_end=t_end),
        "midpoint": dth.integrate(kepler, z0, "midpoint", dt=0.02, t_end=t_end),
        "trapezoidal": dth.integrate(kepler, z0, "trapezoidal", dt=0.02, t_end=t_end),
    }
    for name, s in runs.items():
        print(f"{name:12s} {s.steps:6d} steps, max |H - H0| = {np.max(np.abs(s.energy_error)):.1e}")
    if figure is None:
        return
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name, s in runs.items():
        ax.semilogy(s.t, np.abs(s.energy_error) + 1e-18, label=name, lw=0.8)
    ax.set_xlabel("t")
    ax.set_ylabel("|H - H0|")
    ax.set_title("Kepler, e = 0.44: energy error")
    ax.legend()
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
