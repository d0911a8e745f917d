"""The Henon-Heiles surface of section at E = 1/8 from the shipped scene (an ensemble of
starts on the energy shell, DTH to t = 2000), its crossings read back as numpy arrays.

Run: python henon_heiles_section.py [figure.png] [t_end]   (the figure needs matplotlib)
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np

import dth

SCENE = Path(__file__).resolve().parents[2] / "dth-examples" / "scenes" / "henon-heiles-section.toml"


def main(figure: str | None, t_end: float) -> None:
    text = re.sub(r"(?m)^time = .*$", f"time = {t_end}", SCENE.read_text())
    run = dth.run_scene(text)
    crossings = run.arrays["ensemble_crossings"]  # member, method, section, t, x = q2, y = p2
    q2, p2 = crossings["x"], crossings["y"]
    counts = run.summary["ensemble"]
    members = counts["drawn"] - counts["skipped"]
    print(f"{len(q2)} crossings of q1 = 0 from {members} members on the energy shell")
    if figure is None:
        return
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(q2, p2, ",", color="k")
    ax.set_xlabel("q2")
    ax.set_ylabel("p2")
    ax.set_title("Henon-Heiles, E = 1/8, section q1 = 0")
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


if __name__ == "__main__":
    main(
        sys.argv[1] if len(sys.argv) > 1 and sys.argv[1] != "-" else None,
        float(sys.argv[2]) if len(sys.argv) > 2 else 2000.0,
    )
