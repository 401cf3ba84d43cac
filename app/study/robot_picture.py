"""A robot drawn with each leg joint's axis and name (`artro robot show --png`): the mapping of
an imported robot to look at before trusting it (docs/DESIGN.md §16); matplotlib, Agg backend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from app.robots.cad_import import mapping_rows
from app.robots.model import RobotModel

AXIS_DRAWN_M = 0.04  # how long each joint's axis is drawn


def draw_robot(robot: RobotModel, path: Path) -> Path:
    """Draw the legs standing, front and side views, each joint's axis an arrow along its
    positive paper angle, labelled with its gait name (and the file's joint); write PNG."""
    axes_of = robot.leg_axes()
    file_joint = {
        row["joint"]: f" ({row['file_joint']}, {row['sign']:+d})"
        for row in mapping_rows(robot.description)
    }
    figure = Figure(figsize=(14, 8), dpi=100)
    for k, (title, (h, v)) in enumerate(
        (
            ("from the front (its left on your right)", (1, 2)),
            ("from its left (toes to the right)", (0, 2)),
        )
    ):
        ax = figure.add_subplot(1, 2, k + 1)
        for side, colour in (("l", "tab:blue"), ("r", "tab:red")):
            chain = np.array([axes_of[f"{side}_{j}"][0] for j in _ORDER])
            ax.plot(chain[:, h], chain[:, v], "-o", color=colour, lw=1)
            for joint in _ORDER:
                name = f"{side}_{joint}"
                anchor, axis = axes_of[name]
                x0, y0 = anchor[h], anchor[v]
                dx = AXIS_DRAWN_M * axis[h]
                dy = AXIS_DRAWN_M * axis[v]
                ax.annotate(
                    "",
                    (x0 + dx, y0 + dy),
                    (x0, y0),
                    arrowprops={"arrowstyle": "->", "color": colour},
                )
                if abs(dx) + abs(dy) > 0.2 * AXIS_DRAWN_M:
                    ax.text(
                        x0 + dx,
                        y0 + dy + (0.004 if side == "l" else -0.008),
                        name + file_joint.get(name, ""),
                        fontsize=7,
                        color=colour,
                    )
        points = np.array([a for a, _ in axes_of.values()])
        ax.set_xlim(points[:, h].min() - 0.08, points[:, h].max() + 0.12)
        ax.set_ylim(points[:, v].min() - 0.03, points[:, v].max() + 0.05)
        ax.set_title(f"{robot.name}: {title}")
        ax.set_aspect("equal")
        ax.set_xlabel("m")
        ax.grid(alpha=0.3)
    figure.text(
        0.01,
        0.01,
        "arrows: each joint's axis; a positive paper angle turns about it "
        "by the right-hand rule (docs/DESIGN.md §3)",
        fontsize=8,
    )
    FigureCanvasAgg(figure).print_png(str(path))
    return path


_ORDER = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
