"""Noise sweep: how each method degrades as one noise source grows, and under whole profiles.

Worlds: the shipped real-style worlds R1-R3 and, per generator style (R1-style, R2-style,
R3-style), ``layouts`` freshly generated layouts with seeds ``layout_seed + i`` (``--layout-seed``,
default ``UNSEEN_LAYOUT_SEED_BASE``: 2^31, 2^31 + 1, ...; :mod:`d3dwa_bullet.world.generator`).
Training draws generator seeds below 2^31, so these layouts are never seen in training. Layout group ``shipped`` holds
the shipped worlds named in ``--worlds`` (default R1-R3), ``given`` any other ``--worlds`` entry
(a generated layout by name, a world file), ``generated`` the unseen layouts.

Noise: one axis at a time, from 0 to a harsh value in ``levels`` equal steps, every other
model off; then the named profiles (none, paper, real, harsh), sampled per episode as in
training. An axis level is an explicit :class:`NoiseConfig` (the episode runs with
``NoiseModel(config, seed)``):

================  =======================================================  ==========
axis              what a level L sets                                       top (harsh)
================  =======================================================  ==========
lidar_dropout     lidar.dropout_prob = L; dropped beams NaN/+inf/0 as 1:7:2    0.5
lidar_range       lidar.range_std = L m                                        0.10 m
slip              slip.level_mean = L, level_std = L/4, step_std = L/10        0.4
odometry          odometry radius/track error std = L, walk = L m/sqrt(s),     0.04
                  yaw walk = L rad/sqrt(s)
================  =======================================================  ==========

Level 0 of every axis and the profile ``none`` are the same noise-free episode (a
NoiseModel with every model off is bit-identical to no noise), so it runs once: its rows
have axis ``none``, level 0 and noise ``none``, and serve as level 0 of each axis and as
the ``none`` profile. Other rows have noise ``<axis>=<level>`` (e.g. ``slip=0.2``) or the
profile name, axis the axis name or ``profile``, and level the axis value (empty for
profiles).

Statistics (:mod:`d3dwa_bullet.evaluation.stats`): success rate with the Wilson score
interval (95 %), time to goal over the successful episodes with the 95 % Student t-interval
of the mean.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from d3dwa_bullet.dir_lock import locked_dir
from d3dwa_bullet.episode import EpisodeConfig
from d3dwa_bullet.evaluation.barn_tables import TERCILE_ORDER, tercile_group
from d3dwa_bullet.evaluation.floors import chance_sections
from d3dwa_bullet.evaluation.jobs import Job, evaluate, noise_config_json
from d3dwa_bullet.evaluation.noise_axes import AXES
from d3dwa_bullet.evaluation.page_width import fit_prose, world_span
from d3dwa_bullet.evaluation.plotting import sweep_figure
from d3dwa_bullet.evaluation.policy_runs import method_runs
from d3dwa_bullet.evaluation.results import (
    CSV_FIELDS,
    completion,
    once_per_layout,
    read_results,
    row_key,
)
from d3dwa_bullet.evaluation.reuse import Reuse
from d3dwa_bullet.evaluation.same_run import check_resumable
from d3dwa_bullet.evaluation.score_tables import score_condition_tables
from d3dwa_bullet.evaluation.scores import UNSCORED_NOTE, is_scored
from d3dwa_bullet.evaluation.seed_tables import condition_table
from d3dwa_bullet.evaluation.stats import Series, group_series
from d3dwa_bullet.evaluation.style_tables import style_section
from d3dwa_bullet.evaluation.sweep_meta import sweep_meta
from d3dwa_bullet.evaluation.sweep_settings import (
    BASELINE,
    SweepSettings,
    episode_count,
)
from d3dwa_bullet.evaluation.tables import repeats_note, run_notes, series_table
from d3dwa_bullet.evaluation.training_worlds import (
    group_flag,
    trained_worlds,
    training_lines,
)
from d3dwa_bullet.io import atomic_write_text
from d3dwa_bullet.learning.agents.barn_record import BarnTraining
from d3dwa_bullet.limits import MAX_EPISODES
from d3dwa_bullet.world import barn_style
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE, generate_world
from d3dwa_bullet.world.generator_spec import load_generator
from d3dwa_bullet.world.model import World
from d3dwa_bullet.world.registry import load_world, world_paths

SWEEP_FIELDS = (*CSV_FIELDS[:5], "axis", "level", "layout", *CSV_FIELDS[5:])
LAYOUT_GROUPS = ("shipped", "given", *TERCILE_ORDER, barn_style.GROUP, "generated")
"""Where a sweep's layout comes from: a shipped world named in --worlds; any other --worlds
entry (a generated layout by name, or a world file); a BARN world (``--suite barn``), by its
difficulty tercile (barn-easy, barn-middle, barn-hard); a BARN-style world (``--suite
barn-style``, never BARN's); one of the --layouts unseen layouts."""


@dataclass(frozen=True)
class Condition:
    """One noise condition of the sweep."""

    axis: str
    """An AXES name, "profile", or "none" (the shared noise-free baseline)."""
    level: float | None
    """The axis value (0 for the baseline, None for a profile)."""
    noise: str
    """The jobs' noise label: "none", "<axis>=<level>" or a profile name."""
    noise_config: str | None = None
    """JSON NoiseConfig for axis levels; None for profiles and the baseline."""


def conditions(settings: SweepSettings) -> list[Condition]:
    """The baseline, every axis level, then every profile but none (= the baseline)."""
    out = [Condition(BASELINE, 0.0, BASELINE)]
    for name in settings.axes:
        axis = AXES[name]
        for level in axis.levels(settings.levels):
            out.append(
                Condition(name, level, f"{name}={level:g}", noise_config_json(axis.build(level)))
            )
    out += [Condition("profile", None, p) for p in settings.profiles if p != BASELINE]
    return out


def unseen_layout_seeds(layouts: int, first: int = UNSEEN_LAYOUT_SEED_BASE) -> list[int]:
    """Generator seeds of the unseen layouts: first, first + 1, ... (first: ``--layout-seed``,
    2^31 by default)."""
    return [first + i for i in range(layouts)]


def given_group(name: str) -> str:
    """The layout group of a --worlds entry: "shipped" for a shipped world's name, a BARN
    world's tercile group for its name (BARN-17), "barn-style" for a BARN-style world's,
    "given" for anything else (a generated layout by name, a world file)."""
    if name.upper() in {n.upper() for n in world_paths()}:
        return "shipped"
    return tercile_group(name) or barn_style.barn_style_group(name) or "given"


def sweep_worlds(settings: SweepSettings, progress: bool = False) -> list[tuple[World, str]]:
    """(world, layout group) pairs (:data:`LAYOUT_GROUPS`), with the time-limit override
    applied. Generating a layout takes about 0.1 s, so (with progress) a bar counts them:
    2,250 take minutes before the first episode."""
    pairs = [(load_world(w), given_group(w)) for w in settings.worlds]
    for style in settings.styles:
        load_generator(style)  # an unknown style is refused alone, before the bar starts
    todo = [
        (style, seed)
        for style in settings.styles
        for seed in unseen_layout_seeds(settings.layouts, settings.layout_seed)
    ]
    with tqdm(
        todo, disable=not (progress and todo), desc="layouts", unit="layout", leave=False
    ) as bar:
        pairs += [(generate_world(style, seed), "generated") for style, seed in bar]
    if settings.time_limit is not None:
        pairs = [(w.with_task(time_limit=settings.time_limit), g) for w, g in pairs]
    return pairs


def sweep_jobs(
    settings: SweepSettings, policy: str | None = None, progress: bool = False
) -> list[Job]:
    """Every episode of the sweep: worlds x (methods x training seeds) x conditions x seeds."""
    seeds = range(settings.first_seed, settings.first_seed + settings.seeds)
    runs = method_runs(settings.methods, policy, settings.policy_seeds, settings.policy_root)
    MAX_EPISODES.check("sweep", episode_count(settings, len(runs)), "episodes")
    return [
        Job(world, run.method, seed, c.noise, run.policy, c.noise_config,
            (("axis", c.axis), ("level", "" if c.level is None else c.level), ("layout", group)),
            policy_seed=run.policy_seed)
        for world, group in sweep_worlds(settings, progress)
        for run in runs
        for c in conditions(settings)
        for seed in seeds
    ]  # fmt: skip


def read_sweep(out: str | Path) -> list[dict[str, Any]]:
    """Rows of a sweep's results.csv, level as float (None for profiles)."""
    rows = read_results(Path(out))
    for r in rows:
        r["level"] = float(r["level"]) if r.get("level", "") != "" else None
    return rows


def axis_series(rows: Sequence[Mapping[str, Any]], axis: str, methods: Sequence[str]) -> Series:
    """Stats per layout group, method and level of one axis; level 0 is the baseline."""
    groups: dict[tuple[str, str, float], list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        if r["axis"] == BASELINE:
            groups[(r["layout"], r["method"], 0.0)].append(r)
        elif r["axis"] == axis:
            groups[(r["layout"], r["method"], r["level"])].append(r)
    return group_series(groups, LAYOUT_GROUPS, methods)


def profile_of(row: Mapping[str, Any]) -> str | None:
    """The profile a row ran under (none = the baseline), None for an axis level."""
    if row["axis"] == BASELINE:
        return BASELINE
    return row["noise"] if row["axis"] == "profile" else None


def profile_series(
    rows: Sequence[Mapping[str, Any]], profiles: Sequence[str], methods: Sequence[str]
) -> Series:
    """Stats per layout group, method and profile (none = the baseline)."""
    groups: dict[tuple[str, str, str], list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        name = profile_of(r)
        if name in profiles:
            groups[(r["layout"], r["method"], name)].append(r)
    order = {p: i for i, p in enumerate(profiles)}
    return group_series(groups, LAYOUT_GROUPS, methods, key=lambda x: order[x])


def layout_titles(settings: SweepSettings) -> dict[str, str]:
    """Column titles of the layout groups that the settings have; a group's worlds named one
    by one, or counted beyond ``page_width.TITLE_WORLDS``."""
    titles = {}
    labels = [("shipped", "shipped worlds"), ("given", "worlds given")]
    labels += [(g, f"BARN {g.removeprefix('barn-')} tercile") for g in TERCILE_ORDER]
    labels += [(barn_style.GROUP, "BARN-style worlds (not BARN's)")]
    for group, label in labels:
        names = [Path(w).stem if Path(w).suffix else w
                 for w in settings.worlds if given_group(w) == group]  # fmt: skip
        if names:  # a whole BARN split's tercile is ~80 worlds: counted, not listed
            titles[group] = f"{label}: {world_span(names)}"
    seeds = unseen_layout_seeds(settings.layouts, settings.layout_seed)
    if seeds and settings.styles:
        span = f"{seeds[0]}" if len(seeds) == 1 else f"{seeds[0]}..{seeds[-1]}"
        titles["generated"] = (
            f"unseen layouts: {settings.layouts} per {', '.join(settings.styles)} "
            f"(generator seeds {span})"
        )
    return titles


def sweep_figures(
    rows: Sequence[Mapping[str, Any]], settings: SweepSettings, fig_dir: Path, partial: bool = False
) -> list[Path]:
    """figures/sweep_<axis>.png per axis and figures/sweep_profiles.png."""
    note = " (PARTIAL: sweep incomplete)" if partial else ""
    titles = layout_titles(settings)
    paths = []
    for name in settings.axes:
        series = axis_series(rows, name, settings.methods)
        if series:
            paths.append(
                sweep_figure(
                    series,
                    titles,
                    AXES[name].label,
                    fig_dir / f"sweep_{name}.png",
                    title=f"Noise sweep: {AXES[name].label}{note}",
                )  # fmt: skip
            )
    series = profile_series(rows, settings.profiles, settings.methods)
    if series:
        paths.append(
            sweep_figure(
                series,
                titles,
                "randomisation profile",
                fig_dir / "sweep_profiles.png",
                title=f"Named noise profiles{note}",
                bars=True,
            )  # fmt: skip
        )
    return paths


def sweep_markdown(
    rows: Sequence[Mapping[str, Any]],
    settings: SweepSettings,
    barn_training: Mapping[str, BarnTraining] | None = None,
) -> str:
    """Per-axis and per-profile tables: successes/episodes, mean time to goal ± 95 % CI. A
    method that trained on BARN worlds (barn_training) has its line first, and its rows of a
    tercile holding some of them say how many (``training_worlds``). Every line fits the
    page's width (``page_width``)."""
    titles = layout_titles(settings)
    training = barn_training or {}
    flag = group_flag(trained_worlds(training))
    members = {g: [w for w in settings.worlds if given_group(w) == g] for g in TERCILE_ORDER}

    def layout_flag(method: str, group: str) -> str:
        return flag(method, members.get(group, ()))

    parts = [
        training_lines(training, settings.worlds),
        "Cells: successes/episodes, mean time to goal of the successes ± half-width of the "
        "95 % t-interval; then the mean episode score (docs/design/score.md#score). Layouts: "
        + "; ".join(f"*{k}* = {v}" for k, v in titles.items())
        + ".\n",
    ]
    if not is_scored(rows):
        parts.append(f"\n{UNSCORED_NOTE}\n")
    if note := repeats_note(settings.seeds, settings.methods):  # the noise-free cells
        parts.append("\n" + note.rstrip("\n") + "\n")
    for name in settings.axes:
        axis = AXES[name]
        levels = [0.0, *axis.levels(settings.levels)]
        parts.append(f"\n### {axis.label} (`{name}`)\n\n")
        parts.append(series_table(axis_series(rows, name, settings.methods), levels, layout_flag))
    if settings.profiles:
        parts.append("\n### Named profiles\n\n")
        series = profile_series(rows, settings.profiles, settings.methods)
        parts.append(series_table(series, settings.profiles, layout_flag))
        parts.append(
            "\n### Named profiles over training seeds\n\nSuccess rate [%] averaged over the "
            "layouts of a group, 95 % stratified bootstrap over runs (a learned method's "
            "training seeds, the evaluation seeds of a fixed or reference method).\n\n"
        )
        groups = [g for g in LAYOUT_GROUPS if g in titles]
        parts.append(
            condition_table(rows, settings.methods, settings.profiles, profile_of,
                            groups, lambda r: r["layout"], flag=flag)
        )  # fmt: skip
        parts.append(
            "\n### Named profiles: score over training seeds\n\nPer run the mean episode "
            "score (docs/design/score.md#score), averaged over the layouts of a group; 95 % "
            "stratified bootstrap over runs.\n\n"
        )
        parts.append(
            score_condition_tables(rows, settings.methods, settings.profiles, profile_of,
                                   groups, lambda r: r["layout"], flag)
        )  # fmt: skip
        parts.append(style_section(rows, settings.methods, settings.profiles, profile_of, flag))
    parts.append(chance_sections(rows, settings.methods, "###", " (every layout and condition)"))
    return fit_prose("".join(parts))


def summary_records(rows: Sequence[Mapping[str, Any]], settings: SweepSettings) -> list[dict]:
    """Flat stats records (axis, x, method, layout, n, successes, rate, CIs) for --json;
    undefined values (no success, n < 2) are None."""
    out = []
    named = [(a, axis_series(rows, a, settings.methods)) for a in settings.axes]
    named.append(("profile", profile_series(rows, settings.profiles, settings.methods)))
    for axis, series in named:
        for layout, per_method in series.items():
            for m, points in per_method.items():
                for x, s in points:
                    stats = {k: None if isinstance(v, float) and math.isnan(v) else v
                             for k, v in asdict(s).items()}  # fmt: skip
                    out.append({"axis": axis, "x": x, "method": m, "layout": layout} | stats)
    return out


def run_sweep(
    settings: SweepSettings,
    out: str | Path,
    workers: int = 1,
    ray_address: str | None = None,
    config: EpisodeConfig = EpisodeConfig(),
    progress: bool = True,
    policy: str | None = None,
    command: str = "",
    figures: bool = True,
    reuse: Reuse | None = None,
) -> tuple[list[dict[str, Any]], bool]:
    """Run (or resume) a sweep into out; returns (rows, complete). When complete, writes
    sweep.md and (with figures) figures/sweep_*.png. reuse: see ``jobs.evaluate``."""
    out = Path(out)
    meta, training = sweep_meta(settings, config, policy, command)
    notes = meta["policy_notes"]
    with locked_dir(out):  # one writer: the episodes, then the page and figures
        # refused (held, another time limit, ...) before minutes of generating layouts
        check_resumable(out, SWEEP_FIELDS, config, meta, settings.methods)
        jobs = sweep_jobs(settings, policy, progress)
        evaluate(jobs, out, workers, config, progress, ray_address, SWEEP_FIELDS, meta, reuse)
        keys = {j.key for j in jobs}
        rows = once_per_layout([r for r in read_sweep(out) if row_key(r) in keys])
        done, expected = completion(out, rows)
        complete = done == expected
        if complete and figures:
            sweep_figures(rows, settings, out / "figures")
        if complete:
            page = "# Noise sweep\n\n" + run_notes(config.recovery_name, notes, config.scan_filter)
            page += sweep_markdown(rows, settings, training)
            atomic_write_text(out / "sweep.md", fit_prose(page))
    return rows, complete
