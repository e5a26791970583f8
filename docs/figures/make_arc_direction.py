"""Draws docs/figures/arc_direction.png: which way a scenario's `arc` turns.

Run from the repository root: `.venv/bin/python docs/figures/make_arc_direction.py`.
"""

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.plots.figures import pyplot
from dloplan.shapes import arc_shape, place

plt = pyplot()
figure, axes = plt.subplots(1, 2, figsize=(9, 4))
for ax, (title, rotation) in zip(axes, (("placement without rotation: the x-y plane", None),
                                         ("rotation {euler: [0, 0, 90]}: turned about z",
                                          Rotation.from_euler("z", 90, degrees=True))),
                               strict=True):
    for angle, colour in ((90, "#1976d2"), (-90, "#d32f2f"), (0, "0.5")):
        shape = place(arc_shape(0.5, 12, np.radians(angle)), np.zeros(3), rotation)
        ax.plot(shape[:, 0], shape[:, 1], "-o", ms=3, color=colour, label=f"angle: {angle}")
        ax.annotate("", shape[-1, :2], shape[-2, :2],
                    arrowprops={"arrowstyle": "->", "color": colour})
    ax.plot(0, 0, "ks")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
figure.suptitle("arc: from the placement's position, its chord along the placement's x-axis;\n"
                "a positive angle turns the tangent counter-clockwise seen from +z (the arc "
                "bulges toward -y)", fontsize=9)
figure.tight_layout()
figure.savefig(Path(__file__).with_name("arc_direction.png"), dpi=110)
