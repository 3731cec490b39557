"""Figures: trajectories over the map, coloured by elapsed time or by the selected horizon."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Circle, Patch, Polygon  # noqa: E402

from d3dwa_bullet.io import atomic_savefig  # noqa: E402
from d3dwa_bullet.method_specs import METHODS, barn_twin, method_label, reference_of  # noqa: E402
from d3dwa_bullet.params import RECOVERY_BEHAVIOURS  # noqa: E402
from d3dwa_bullet.planning.actions import ACTIONS_FULL  # noqa: E402
from d3dwa_bullet.world.model import Cylinder, World, obstacle_outline  # noqa: E402


def draw_world(ax: plt.Axes, world: World) -> None:
    """Obstacles (grey), start (black triangle) and goal (red star and tolerance) on ax."""
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
    ax: plt.Axes, x: np.ndarray, y: np.ndarray, colour: np.ndarray, norm, cmap: Any
) -> LineCollection:
    """A path whose segments are coloured by colour (N,) under norm."""
    pts = np.column_stack((x, y)).reshape(-1, 1, 2)
    segs = np.concatenate([pts[:-1], pts[1:]], axis=1)
    lc = LineCollection(segs, cmap=cmap, norm=norm, linewidths=2.2, zorder=3)
    lc.set_array(colour[: len(segs)] if len(colour) >= len(segs) else np.resize(colour, len(segs)))
    ax.add_collection(lc)
    return lc


GLOBAL_PATH_STYLE = {"color": "#1565c0", "lw": 0.9, "ls": (0, (3, 2)), "zorder": 4}
"""The global paths of a run (``--global-plan``, docs/design/global-plan.md): dashed blue, the
later the darker."""


def draw_global_paths(ax: plt.Axes, paths: Sequence[np.ndarray] | None) -> bool:
    """Draw a run's global paths (each (K, 2) m, in the order found; None or none: nothing),
    the first faint, the last opaque; returns whether it drew."""
    paths = [p for p in paths or () if len(p) > 1]
    for k, path in enumerate(paths):
        alpha = 0.15 + 0.85 * (k + 1) / len(paths)
        ax.plot(path[:, 0], path[:, 1], alpha=alpha, **GLOBAL_PATH_STYLE)  # type: ignore[arg-type]
    return bool(paths)


RECOVERY_COLOURS = {"spin": "#00c853", "back_up": "#00b8d4"}
"""Colours of the steps each recovery behaviour drove: green and cyan, apart from the
plasma and viridis maps the path is coloured with."""


def draw_recoveries(ax: plt.Axes, x: np.ndarray, y: np.ndarray, codes: Any) -> set[str]:
    """Draw the segments of a path (N + 1 poses) whose step (N codes, 0 = no recovery, k =
    RECOVERY_BEHAVIOURS[k - 1]) a recovery drove; returns the behaviours drawn."""
    if codes is None or len(codes) == 0:
        return set()
    codes = np.asarray(codes)
    pts = np.column_stack((x, y)).reshape(-1, 1, 2)
    segs = np.concatenate([pts[:-1], pts[1:]], axis=1)[: len(codes)]
    codes = codes[: len(segs)]
    drawn = set()
    for k, behaviour in enumerate(RECOVERY_BEHAVIOURS, start=1):
        mask = codes == k
        if mask.any():
            ax.add_collection(
                LineCollection(segs[mask], colors=RECOVERY_COLOURS[behaviour], linewidths=5.0,
                               zorder=4, capstyle="round")
            )  # fmt: skip
            drawn.add(behaviour)
    # A spin turns in place, so its segments are dots: ring and number every recovery's start.
    starts = np.flatnonzero((codes > 0) & ~np.concatenate(([False], codes[:-1] > 0)))
    for n, i in enumerate(starts, start=1):
        colour = RECOVERY_COLOURS[RECOVERY_BEHAVIOURS[int(codes[i]) - 1]]
        ax.plot(x[i], y[i], marker="o", ms=11, mfc="none", mec=colour, mew=2.2, zorder=5)
        ax.annotate(str(n), (x[i], y[i]), xytext=(6, 6), textcoords="offset points",
                    fontsize=7, color="k", zorder=6)  # fmt: skip
    return drawn


def view_bounds(world: World, runs: Sequence[dict], margin: float = 0.3) -> tuple[float, ...]:
    """(xmin, ymin, xmax, ymax) of the world and every run's path, plus margin, m."""
    xmin, ymin, xmax, ymax = world.bounds(margin=margin)
    for r in runs:
        if len(r["x"]):
            xmin, xmax = min(xmin, np.min(r["x"]) - margin), max(xmax, np.max(r["x"]) + margin)
            ymin, ymax = min(ymin, np.min(r["y"]) - margin), max(ymax, np.max(r["y"]) + margin)
    return float(xmin), float(ymin), float(xmax), float(ymax)


OUTCOME_STYLE = {
    "goal": ("reached", "#1a9850", "o"),
    "timeout": ("timeout", "#e08214", "s"),
    "collision": ("collision", "#d73027", "X"),
}
"""outcome -> (word, colour, end-of-path marker): the panel's outcome, readable at a glance."""
MAX_COLUMNS = 4
"""Panels per row of a trajectory figure: twelve methods make a 4 x 3 grid whose panels keep
about 3 inches each, and their titles room to be read."""


def panel_grid(n: int) -> tuple[int, int]:
    """(rows, columns) of a figure of n panels: one row up to MAX_COLUMNS, then rows of it."""
    columns = min(max(n, 1), MAX_COLUMNS)
    return -(-max(n, 1) // columns), columns


def _outcome_style(outcome: str) -> tuple[str, str, str]:
    return OUTCOME_STYLE.get(outcome, (str(outcome), "0.3", "D"))


def _outcome_order(outcome: str) -> tuple[int, str]:
    order = list(OUTCOME_STYLE)
    return (order.index(outcome) if outcome in order else len(order), outcome)


def _end_mark(outcome: str, size: float = 1.0) -> dict[str, Any]:
    """Marker keywords of the end of a path: a ring round the goal star for a reached goal
    (the star stays visible), a filled mark of the outcome's colour otherwise."""
    _, colour, mark = _outcome_style(outcome)
    if outcome == "goal":
        return {"marker": mark, "ms": 17 * size, "mfc": "none", "mec": colour, "mew": 2.5}
    return {"marker": mark, "ms": 11 * size, "mfc": colour, "mec": "white", "mew": 1.2}


def horizon_colours(taus: np.ndarray) -> tuple[Any, Any, np.ndarray]:
    """(norm, colour map, ticks) for paths coloured by the selected horizon: one colour per
    horizon, the action set's (2, 3, 4, 5 s) and any other finite value in taus (s), with
    boundaries halfway between them, so the colour bar is in bands, not a continuous scale."""
    finite = taus[np.isfinite(taus)] if taus.size else taus
    values = np.unique(np.concatenate([np.asarray(ACTIONS_FULL.horizons, float), finite]))
    mids = (values[:-1] + values[1:]) / 2
    edges = np.concatenate([[values[0] - 0.5], mids, [values[-1] + 0.5]])
    cmap = plt.get_cmap("viridis").resampled(len(values))
    return matplotlib.colors.BoundaryNorm(edges, len(values)), cmap, values


def trajectory_figure(
    world: World,
    runs: Sequence[dict],
    path: str | os.PathLike[str],
    colour_by: str = "time",
    title: str | None = None,
) -> Path:
    """One panel per run, in a grid of at most MAX_COLUMNS columns: each run is a dict with
    keys label (short: the panel's title), outcome, t, x, y, tau (arrays, s and m), and
    optionally recovery (the per-step log's codes: the steps a recovery behaviour drove are
    drawn over the path in its own colour, RECOVERY_COLOURS) and plan (the run's global paths,
    each (K, 2) m, in the order found: dashed, the later the darker). colour_by: "time" or "tau".

    Each panel's outcome is its title's right-hand word in the outcome's colour and a mark
    of that colour where the path ends (OUTCOME_STYLE); one legend and one colour bar serve
    every panel, and only the outer panels carry axis labels.
    """
    n = max(1, len(runs))
    rows, columns = panel_grid(n)
    xmin, ymin, xmax, ymax = view_bounds(world, runs)
    aspect = (ymax - ymin) / max(xmax - xmin, 1e-6)
    width = 4.2 if n <= 3 else 3.2
    height = min(max(width * aspect, 1.2), 2.5 * width)
    fig, axes = plt.subplots(
        rows, columns, figsize=(width * columns + 1.4, (0.9 * height + 0.45) * rows + 1.0),
        squeeze=False, sharex=True, sharey=True, layout="constrained",
    )  # fmt: skip
    ticks = None
    if colour_by == "tau":
        norm, cmap, ticks = horizon_colours(np.concatenate([r["tau"] for r in runs] or [[]]))
        label = "selected horizon tau [s]"
    else:
        tmax = max([float(r["t"][-1]) for r in runs if len(r["t"])] or [1.0])
        norm = matplotlib.colors.Normalize(vmin=0.0, vmax=max(tmax, 1e-3))
        cmap, label = "plasma", "elapsed time [s]"
    lc = None
    drawn: set[str] = set()
    planned = False
    outcomes: list[str] = []
    panels = axes.ravel()
    for ax, run in zip(panels, runs, strict=False):
        draw_world(ax, world)
        word, colour, mark = _outcome_style(run["outcome"])
        if len(run["x"]) > 1:
            lc = draw_path(
                ax, run["x"], run["y"], run["tau"] if colour_by == "tau" else run["t"], norm, cmap
            )
            drawn |= draw_recoveries(ax, run["x"], run["y"], run.get("recovery"))
        planned |= draw_global_paths(ax, run.get("plan"))
        if len(run["x"]):
            ax.plot(run["x"][-1], run["y"][-1], ls="", zorder=6, **_end_mark(run["outcome"]))
        outcomes.append(run["outcome"])
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_title(run["label"], loc="left", fontsize=9)
        ax.set_title(word, loc="right", fontsize=9, color=colour, fontweight="bold")
    for ax in panels[len(runs) :]:  # the grid's spare cells
        ax.set_axis_off()
    for ax in panels:  # one x label per column, one y label per row
        ax.label_outer()
    fig.legend(
        handles=[
            Line2D([], [], marker=(3, 0, -90), color="k", ls="", label="start"),
            Line2D([], [], marker="*", color="red", ms=10, ls="", label="goal"),
            Patch(color="0.55", label="obstacle"),
            *([Line2D([], [], **GLOBAL_PATH_STYLE, label="global paths")] if planned else []),
            *(Line2D([], [], ls="", label=f"end: {_outcome_style(o)[0]}", **_end_mark(o, 0.7))
              for o in sorted(set(outcomes), key=_outcome_order)),
            *(Line2D([], [], color=RECOVERY_COLOURS[b], lw=4, label=f"recovery: {b}")
              for b in RECOVERY_BEHAVIOURS if b in drawn),
        ],
        loc="outside lower center", ncol=8, fontsize=8, frameon=False,
    )  # fmt: skip
    if lc is not None:
        bar = fig.colorbar(lc, ax=axes.ravel().tolist(), label=label, shrink=0.85 / rows**0.5)
        if ticks is not None:  # one band per horizon: tau takes only these values
            bar.set_ticks(ticks, labels=[f"{t:g}" for t in ticks])
            bar.minorticks_off()
    fig.suptitle(title or f"{world.name}: {world.description}", fontsize=10)
    return _save(fig, path)


REFERENCE_COLOURS = {"random": (0.45, 0.45, 0.45, 1.0), "random-weights": (0.72, 0.72, 0.72, 1.0)}
"""The colours of the reference methods: greys, floors rather than contenders (a held one a
darker grey than its every-step draw)."""
HELD_DARKER = 0.2
_COLOURED = tuple(m for m in METHODS if reference_of(m) is None and barn_twin(m) is None)
CONTENDER_SLOTS = (0, 1, 2, 3, 4, 5, 6, 8, 9)
"""The tab10 colours a contender may take: all but its grey (slot 7), which the eighth
contender took beside the reference methods' greys once the method list grew."""


def _reference_colour(method: str) -> tuple | None:
    ref = reference_of(method)
    if ref is None:
        return None
    r, g, b, a = REFERENCE_COLOURS[ref[0]]
    dark = HELD_DARKER if ref[1] > 1 else 0.0
    return (r - dark, g - dark, b - dark, a)


def method_colours(methods: Sequence[str]) -> dict[str, tuple]:
    """A stable colour per method name: a reference method grey, a BARN-trained one its twin's
    colour lightened, every other one its slot in the order of d3dwa_bullet.method_specs.METHODS
    (reference methods left out, so adding one changes no other method's colour)."""
    palette = [plt.get_cmap("tab10")(k) for k in CONTENDER_SLOTS]
    n = len(palette)

    def colour(i: int, m: str) -> tuple:
        twin = barn_twin(m)
        if twin is not None:  # the twin's hue, halfway to white: the pair reads as one family
            return (*(0.5 + 0.5 * c for c in colour(i, twin)[:3]), 1.0)
        return palette[_COLOURED.index(m) % n if m in _COLOURED else i % n]

    return {m: _reference_colour(m) or colour(i, m) for i, m in enumerate(methods)}


def save_figure(fig: plt.Figure, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Write fig to path atomically (``io.atomic_savefig``, ``kwargs`` to ``savefig``), making
    its folder, and close it whatever happens: every figure the package and its tools draw."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        return atomic_savefig(fig, out, **kwargs)
    finally:
        plt.close(fig)


def _save(fig: plt.Figure, path: str | os.PathLike[str]) -> Path:
    return save_figure(fig, path, dpi=110, bbox_inches="tight")


LEGEND_COLUMNS = 4
"""Columns of a sweep figure's legend (below the panels)."""


def sweep_figure(
    series: dict,
    column_titles: dict[str, str],
    xlabel: str,
    path: str | os.PathLike[str],
    title: str = "",
    bars: bool = False,
) -> Path:
    """Success rate (top) and time to goal (bottom) against a noise level or profile.

    series: layout group -> method -> [(x, stats)], stats with n, successes, rate,
    rate_lo, rate_hi (Wilson interval) and time_mean, time_lo, time_hi (t-interval, s).
    One column per layout group; lines over numeric levels, grouped bars over profiles.
    Methods are dodged sideways so their error bars do not hide each other.
    """
    layouts = list(series)
    methods = list(dict.fromkeys(m for per in series.values() for m in per))
    colours = method_colours(methods)
    crowded = len(methods) > 3  # count labels wider than their bars: set upright
    legend_rows = -(-len(methods) // LEGEND_COLUMNS)
    fig, axes = plt.subplots(
        2, len(layouts), figsize=(5.6 * len(layouts) + 0.6, 7.2 + 0.22 * legend_rows),
        squeeze=False, sharex="col", layout="constrained",
    )  # fmt: skip
    any_time = [False] * len(layouts)
    for col, layout in enumerate(layouts):
        per_method = series[layout]
        xs_all = list(dict.fromkeys(x for pts in per_method.values() for x, _ in pts))
        if bars:
            pos = {x: float(i) for i, x in enumerate(xs_all)}
            width = 0.8 / max(1, len(methods))
        else:
            span = (max(xs_all) - min(xs_all)) or 1.0
            pos = {x: float(x) for x in xs_all}
            width = 0.012 * span
        for i, m in enumerate(methods):
            pts = per_method.get(m, [])
            if not pts:
                continue
            shift = (i - (len(methods) - 1) / 2) * width
            x = np.array([pos[p] for p, _ in pts]) + shift
            st = [s for _, s in pts]
            rate = np.array([100 * s.rate for s in st])
            err = np.array(
                [[100 * (s.rate - s.rate_lo) for s in st], [100 * (s.rate_hi - s.rate) for s in st]]
            )
            tm = np.array([s.time_mean for s in st])
            terr = np.array(
                # a time is never negative: the t-interval of 2-3 episodes is cut at 0 s
                [
                    [s.time_mean - max(s.time_lo, 0.0) for s in st],
                    [s.time_hi - s.time_mean for s in st],
                ]
            )
            terr = np.nan_to_num(terr, nan=0.0)
            kw = {"color": colours[m], "label": method_label(m)}
            top, bottom = axes[0, col], axes[1, col]
            ok = np.isfinite(tm)
            if bars:
                top.bar(x, rate, width, yerr=err, capsize=2, ecolor="0.25", **kw)
                # counts: a 0 % bar is otherwise invisible; upright when bars crowd
                turn = 90 if crowded else 0
                for xi, s in zip(x, st, strict=True):
                    top.annotate(f"{s.successes}/{s.n}", (xi, 100 * s.rate_hi), ha="center",
                                 va="bottom", fontsize=6, xytext=(0, 1), textcoords="offset points",
                                 rotation=turn)  # fmt: skip
                if ok.any():
                    bottom.bar(
                        x[ok], tm[ok], width, yerr=terr[:, ok], capsize=2, ecolor="0.25", **kw
                    )
            else:
                top.errorbar(x, rate, yerr=err, marker="o", ms=4, capsize=3, lw=1.5, **kw)
                if ok.any():
                    bottom.errorbar(x[ok], tm[ok], yerr=terr[:, ok], marker="o", ms=4, capsize=3,
                                    lw=1.5, **kw)  # fmt: skip
            any_time[col] = any_time[col] or bool(ok.any())
        top, bottom = axes[0, col], axes[1, col]
        top.set_title(column_titles.get(layout, layout), fontsize=9)
        top.set_ylim(-3, (126 if crowded else 108) if bars else 103)
        top.set_yticks(range(0, 101, 20))
        if not any_time[col]:
            bottom.text(0.5, 0.5, "no successful episode", transform=bottom.transAxes,
                        ha="center", va="center", color="0.4")  # fmt: skip
        top.set_ylabel("success rate [%] (Wilson 95 % CI)")
        bottom.set_ylabel("time to goal [s] (successes, 95 % t-CI)")
        bottom.set_ylim(bottom=0.0)
        bottom.set_xlabel(xlabel)
        if bars:
            bottom.set_xticks(list(pos.values()), [str(x) for x in pos])
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    # outside the axes, in room the layout keeps for it: twelve methods take three rows
    fig.legend(handles, labels, loc="outside lower center", ncol=min(LEGEND_COLUMNS, len(labels)),
               fontsize=9)  # fmt: skip
    fig.suptitle(title, fontsize=11)
    return _save(fig, path)
