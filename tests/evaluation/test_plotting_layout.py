"""The figures stay readable as the method list grows (issue 58, class 5): the trajectory
figure's panel titles and the sweep figure's legend are checked on the drawn layout, the
text boxes' extents as the renderer places them."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from d3dwa_bullet.evaluation import plotting
from d3dwa_bullet.evaluation.stats import CellStats
from d3dwa_bullet.method_specs import METHODS, needs_policy, reference_of
from d3dwa_bullet.world.registry import load_world

OUTCOMES = ("goal", "timeout", "collision")


@pytest.fixture
def drawn(monkeypatch) -> list[Figure]:
    """The figures the plotting module would save, kept open and drawn instead."""
    figures: list[Figure] = []

    def keep(fig, path):
        fig.canvas.draw()
        figures.append(fig)
        return path

    monkeypatch.setattr(plotting, "_save", keep)
    yield figures
    for fig in figures:
        plotting.plt.close(fig)


def _extent(text: Text) -> Bbox:
    return text.get_window_extent(text.figure.canvas.get_renderer())


def _apart(a: Bbox, b: Bbox) -> bool:
    return a.x1 <= b.x0 or b.x1 <= a.x0 or a.y1 <= b.y0 or b.y1 <= a.y0


def _titles(fig: Figure) -> list[Text]:
    """Every title drawn: each panel's (left, centre, right) and the figure's."""
    texts = [
        t
        for ax in fig.axes
        for t in (ax.title, ax._left_title, ax._right_title)  # no public getter of the Text
        if t.get_text()
    ]
    return texts + ([fig._suptitle] if fig._suptitle is not None else [])


def _labels(n: int) -> list[str]:
    """n panel labels as the main job names them: the method, and a learned one's seed;
    past the shipped methods, held references of growing periods."""
    names = list(METHODS) + [f"random-weights@{k}" for k in range(11, 11 + max(0, n - 12))]
    return [m + (" · seed 0" if needs_policy(m) else "") for m in names[:n]]


def _run(label: str, k: int) -> dict:
    t = np.linspace(0.0, 30.0 + k, 50)
    return {"label": label, "outcome": OUTCOMES[k % 3], "t": t,
            "x": np.linspace(0.0, 3.0, 50), "y": np.sin(t / 5.0), "tau": np.full(50, 3.0)}  # fmt: skip


@pytest.mark.parametrize("n", [1, 4, len(METHODS), 20])
def test_trajectory_titles_do_not_overlap_whatever_the_method_count(drawn, tmp_path, n):
    plotting.trajectory_figure(
        load_world("H2"), [_run(label, k) for k, label in enumerate(_labels(n))], tmp_path / "f"
    )
    (fig,) = drawn
    titles = _titles(fig)
    for a, b in itertools.combinations(titles, 2):
        assert _apart(_extent(a), _extent(b)), (a.get_text(), b.get_text())
    assert len(titles) == 2 * n + 1  # a label and an outcome per panel, and the figure's
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
    assert len(panels) == n
    for ax in panels:  # a title stays over its own panel
        box = ax.get_window_extent()
        for t in (ax._left_title, ax._right_title):
            assert box.x0 - 1 <= _extent(t).x0 and _extent(t).x1 <= box.x1 + 1, t.get_text()
    assert len(fig.legends) == 1 and not any(ax.get_legend() for ax in fig.axes)
    assert sum(ax.get_label() == "<colorbar>" for ax in fig.axes) == 1
    if n >= len(METHODS):
        rows = {round(ax.get_position().y0, 3) for ax in panels}
        assert len(rows) >= 3  # a grid, not one row of thumbnails


def test_each_outcome_is_named_in_its_colour_and_marked_where_the_path_ends(drawn, tmp_path):
    runs = [_run(f"m{k}", k) for k in range(3)]
    plotting.trajectory_figure(load_world("H2"), runs, tmp_path / "f")
    (fig,) = drawn
    for ax, run in zip(fig.axes, runs, strict=False):
        word, colour, mark = plotting.OUTCOME_STYLE[run["outcome"]]
        assert ax._right_title.get_text() == word and ax._right_title.get_color() == colour
        ends = [line for line in ax.get_lines() if line.get_marker() == mark]
        assert len(ends) == 1 and tuple(ends[0].get_xydata()[-1]) == (3.0, run["y"][-1])
    legend = {t.get_text() for t in fig.legends[0].get_texts()}
    assert {"end: reached", "end: timeout", "end: collision"} <= legend


def _cell(k: int) -> CellStats:
    """Nine episodes, k % 10 of them reaching the goal in 30-50 s."""
    rows = [{"outcome": "goal" if i < k % 10 else "timeout", "time_s": 30.0 + 5 * (i % 5)}
            for i in range(9)]  # fmt: skip
    return CellStats.of(rows)


@pytest.mark.parametrize("bars", [True, False])
def test_the_sweep_legend_leaves_every_axis_label_readable(drawn, tmp_path, bars):
    titles = {"shipped": "shipped worlds: R1, R2, R3, H1, H2", "generated": "unseen layouts"}
    xs = ("none", "real", "harsh") if bars else (0.0, 0.1, 0.2)
    series = {
        g: {m: [(x, _cell(i + j)) for j, x in enumerate(xs)] for i, m in enumerate(METHODS)}
        for g in titles
    }
    plotting.sweep_figure(series, titles, "profile", tmp_path / "s.png", "Sweep", bars=bars)
    (fig,) = drawn
    renderer = fig.canvas.get_renderer()
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    assert len(legend.get_texts()) == len(METHODS)
    for ax in fig.axes:
        for text in [ax.xaxis.label, ax.yaxis.label, *ax.get_xticklabels()]:
            if text.get_text() and text.get_visible():
                assert _apart(box, _extent(text)), text.get_text()
    for a, b in itertools.combinations(_titles(fig), 2):
        assert _apart(_extent(a), _extent(b)), (a.get_text(), b.get_text())


def test_no_contender_is_drawn_in_a_reference_grey():
    colours = plotting.method_colours(list(METHODS))
    contenders = [m for m in METHODS if reference_of(m) is None]
    for m in contenders:
        r, g, b, _ = colours[m]
        assert not (r == g == b), m
    assert len({colours[m] for m in contenders}) == len(contenders)
