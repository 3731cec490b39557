"""Figures: trajectories over the map, coloured by elapsed time or by the selected horizon."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

from .world import Cylinder, World  # noqa: E402

OUTCOME_MARK = {"goal": "reached", "collision": "C: collision", "timeout": "T: timeout"}


def draw_world(ax: plt.Axes, world: World) -> None:
    """Obstacles (grey), start (black triangle) and goal (red star and tolerance) on ax."""
    from .simulator import obstacle_outline

    for ob in world.obstacles:
        if isinstance(ob, Cylinder):
            ax.add_patch(Circle(ob.center, ob.radius, color="0.55", zorder=1))
        else:
            ax.add_patch(Polygon(obstacle_outline(ob), closed=True, color="0.55", zorder=1))
    x, y, yaw = world.start
    ax.plot(x, y, marker=(3, 0, np.degrees(yaw) - 90), color="k", markersize=9, zorder=4)
    ax.plot(*world.goal, marker="*", color="red", markersize=14, zorder=4, label="goal")
    xmin, ymin, xmax, ymax = world.bounds(margin=0.3)
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.25)


def draw_path(
    ax: plt.Axes, x: np.ndarray, y: np.ndarray, colour: np.ndarray, norm, cmap: str
) -> LineCollection:
    """A path whose segments are coloured by colour (N,) under norm."""
    pts = np.column_stack((x, y)).reshape(-1, 1, 2)
    segs = np.concatenate([pts[:-1], pts[1:]], axis=1)
    lc = LineCollection(segs, cmap=cmap, norm=norm, linewidths=2.2, zorder=3)
    lc.set_array(colour[: len(segs)] if len(colour) >= len(segs) else np.resize(colour, len(segs)))
    ax.add_collection(lc)
    return lc


def trajectory_figure(
    world: World,
    runs: Sequence[dict],
    path: str | os.PathLike[str],
    colour_by: str = "time",
    title: str | None = None,
) -> Path:
    """One panel per run, side by side: each run is a dict with keys
    label, outcome, t, x, y, tau (arrays, s and m). colour_by: "time" or "tau".
    """
    n = max(1, len(runs))
    xmin, ymin, xmax, ymax = world.bounds(margin=0.3)
    aspect = (ymax - ymin) / max(xmax - xmin, 1e-6)
    width = min(4.2, 12.0 / n) if n > 3 else 4.2
    fig, axes = plt.subplots(1, n, figsize=(width * n + 1.2, width * aspect + 1.2), squeeze=False)
    if colour_by == "tau":
        taus = np.concatenate([r["tau"] for r in runs if len(r["tau"])] or [np.array([2.0, 5.0])])
        norm = matplotlib.colors.Normalize(vmin=min(2.0, taus.min()), vmax=max(5.0, taus.max()))
        cmap, label = "viridis", "selected horizon tau [s]"
    else:
        tmax = max([float(r["t"][-1]) for r in runs if len(r["t"])] or [1.0])
        norm = matplotlib.colors.Normalize(vmin=0.0, vmax=max(tmax, 1e-3))
        cmap, label = "plasma", "elapsed time [s]"
    lc = None
    for ax, run in zip(axes[0], runs, strict=False):
        draw_world(ax, world)
        if len(run["x"]) > 1:
            lc = draw_path(
                ax, run["x"], run["y"], run["tau"] if colour_by == "tau" else run["t"], norm, cmap
            )
        ax.set_title(
            f"{run['label']}\n{OUTCOME_MARK.get(run['outcome'], run['outcome'])}", fontsize=9
        )
    if lc is not None:
        fig.colorbar(lc, ax=axes[0].tolist(), label=label, shrink=0.85)
    fig.suptitle(title or f"{world.name}: {world.description}", fontsize=10)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, out)
    return out
