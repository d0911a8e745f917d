"""The FPUT-alpha chain of 32 particles started in its lowest mode: the energy spreads into
modes 2, 3, ... and near t = 10,000 comes back almost entirely to mode 1 (FPUT 1955).

Run: python fput_modes.py [figure.png] [t_end]   (the figure needs matplotlib)
"""

from __future__ import annotations

import sys

import numpy as np
import numpy.typing as npt

import dth

N = 32


def mode_energies(z: npt.NDArray[np.float64], modes: int) -> npt.NDArray[np.float64]:
    """Harmonic energies of the first `modes` normal modes of the fixed-end chain, per row."""
    i = np.arange(1, N + 1)
    k = np.arange(1, modes + 1)
    basis = np.sqrt(2 / (N + 1)) * np.sin(np.outer(k, i) * np.pi / (N + 1))
    a = z[:, :N] @ basis.T
    b = z[:, N:] @ basis.T
    omega = 2 * np.sin(k * np.pi / (2 * (N + 1)))
    result: npt.NDArray[np.float64] = 0.5 * (b**2 + (omega * a) ** 2)
    return result


def main(figure: str | None, t_end: float) -> None:
    chain = dth.systems.fput_alpha(n=N, alpha=0.25)
    z0 = np.concatenate([np.sin(np.arange(1, N + 1) * np.pi / (N + 1)), np.zeros(N)])
    times = list(np.linspace(0.0, t_end, 201)[1:-1])
    s = dth.integrate(chain, z0, dtau=0.35, t_end=t_end, save_at=times)
    energies = mode_energies(s.z, 4)
    print(f"max |H - H0| = {np.max(np.abs(s.energy_error)):.1e} over {s.steps} DTH steps")
    print(f"E1 at t = 0: {energies[0, 0]:.4f}, at t = {t_end:g}: {energies[-1, 0]:.4f}")
    if figure is None:
        return
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for k in range(4):
        ax.plot(s.t, energies[:, k], label=f"mode {k + 1}")
    ax.set_xlabel("t")
    ax.set_ylabel("mode energy")
    ax.set_title("FPUT-alpha, N = 32: the recurrence")
    ax.legend()
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


if __name__ == "__main__":
    main(
        sys.argv[1] if len(sys.argv) > 1 and sys.argv[1] != "-" else None,
        float(sys.argv[2]) if len(sys.argv) > 2 else 10_000.0,
    )
