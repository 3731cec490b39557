"""A plan's readings as a figure: each cell's A - B with its 95 % interval, against the margin.

One panel per metric (the robot score, then success in points), one line per cell (A vs B),
one marker per profile. The shaded band is the equivalence margin (±δ): an interval inside it
reads "equivalent", one clear of zero a difference (docs/design/readings.md#readings). The marker says
the reading: filled for a difference, hollow for an equivalence, a cross for an inconclusive
cell, so the figure and the tables cannot disagree.

Drawn by ``plan_readings --figure PATH`` from the records it reads; nothing here computes a
reading.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

PANELS = (("score", "robot score, A - B"), ("success", "success, A - B [points]"))
"""The metrics drawn, in order, with their axis labels."""
_COLOURS = {"none": "#4c72b0", "paper": "#8172b2", "real": "#dd8452", "harsh": "#c44e52"}
_STYLE = {"A better": "o", "B better": "o", "equivalent": "o", "inconclusive": "x", "open": "x"}


def cell_name(record: Mapping[str, Any]) -> str:
    """A cell's line label: 'A vs B' ('best fixed' where B stands for it)."""
    b = "best fixed" if "best_fixed_score" in record else record["b"]
    return f"{record['a']} vs {b}"


def draw(
    records: Sequence[Mapping[str, Any]],
    path: Path,
    title: str,
    stratum: str | None = None,
    panels: Sequence[tuple[str, str]] = PANELS,
) -> Path:
    """Write the figure of records (``plan_readings.read_cells``' records) to path (PNG): the
    pooled cells, or with stratum the readings of that stratum (records read with strata);
    panels: (metric, axis label) drawn, in order. A cell still ``open`` is drawn as inconclusive."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from d3dwa_bullet.evaluation.plotting import save_figure  # with matplotlib, for the figure only

    cells = list(dict.fromkeys(cell_name(r) for r in records))
    profiles = list(dict.fromkeys(r["profile"] for r in records))
    height = 1.2 + 0.42 * len(cells) * max(1, len(profiles)) / 2
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 + 5.5 * (len(panels) > 1), height), sharey=True,
                             squeeze=False)  # fmt: skip
    axes = axes[0]
    for ax, (metric, label) in zip(axes, panels, strict=True):
        scale = 100.0 if metric == "success" else 1.0
        margin = None
        for r in records:
            readings = r["readings"] if stratum is None else r.get("strata", {}).get(stratum, {})
            reading = readings.get(metric)
            if not reading or reading.get("reading") is None or reading.get("difference") is None:
                continue
            margin = reading["margin"] * scale
            k = profiles.index(r["profile"])
            y = cells.index(cell_name(r)) + (k - (len(profiles) - 1) / 2) * 0.22
            colour = _COLOURS.get(r["profile"], "#555555")
            diff, low, high = (reading[key] * scale for key in ("difference", "low", "high"))
            ax.plot([low, high], [y, y], color=colour, linewidth=1.6)
            hollow = reading["reading"] == "equivalent"
            ax.plot(diff, y, _STYLE[reading["reading"]], color=colour, markersize=6,
                    markerfacecolor="white" if hollow else colour)  # fmt: skip
        if margin is not None:
            ax.axvspan(-margin, margin, color="#dddddd", zorder=0, label=f"margin ±{margin:g}")
        ax.axvline(0.0, color="#888888", linewidth=0.8)
        ax.set_xlabel(label)
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(cells)), cells)
    axes[0].invert_yaxis()
    handles = [plt.Line2D([], [], color=_COLOURS.get(p, "#555555"), marker="o", label=p)
               for p in profiles]  # fmt: skip
    handles += [
        plt.Line2D([], [], color="black", marker="o", linestyle="", label="A or B better"),
        plt.Line2D([], [], color="black", marker="o", markerfacecolor="white", linestyle="",
                   label="equivalent"),
        plt.Line2D([], [], color="black", marker="x", linestyle="", label="inconclusive"),
    ]  # fmt: skip
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), frameon=False, fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.97))
    return save_figure(fig, path)
