"""One Markdown page per results directory: ``d3dwa report DIR`` -> ``DIR/report.md``.

The page is computed from ``results.csv`` and ``meta.json`` alone (never from typed
numbers): for ``d3dwa eval`` the paper-layout table, success rates and the trajectory
figures of every world; for ``d3dwa sweep`` one plot and one table per noise axis and for
the named profiles; for both, the learning curves ``policies/<method>/learning_curve.png``
that exist (copied into ``DIR/figures/`` so the page and its images move together). Images
are linked relative to the page.

Completeness is judged against the job list the last run saved in meta.json. An
incomplete directory still gets a page, but it says so at the top and in every table and
figure title; the page is written atomically.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from d3dwa_bullet import __version__
from d3dwa_bullet.errors import ResultsError
from d3dwa_bullet.evaluation import training_worlds as tw
from d3dwa_bullet.evaluation.barn_tables import barn_section
from d3dwa_bullet.evaluation.eval_summary import conditions, score_formulas
from d3dwa_bullet.evaluation.floors import chance_sections
from d3dwa_bullet.evaluation.jobs import figure_name, world_figures
from d3dwa_bullet.evaluation.noise_axes import AXES
from d3dwa_bullet.evaluation.page_width import fit_prose, world_span
from d3dwa_bullet.evaluation.results import (
    check_results_dir,
    completion,
    job_rows,
    once_per_layout,
    read_meta,
    recovery_of,
    row_key,
)
from d3dwa_bullet.evaluation.reuse import reused_note
from d3dwa_bullet.evaluation.score_tables import score_tables
from d3dwa_bullet.evaluation.seed_tables import check_not_mixed, per_seed_table, seed_tables
from d3dwa_bullet.evaluation.sweep import SweepSettings, read_sweep, sweep_figures, sweep_markdown
from d3dwa_bullet.evaluation.tables import (
    paper_table,
    policy_notes,
    repeats_note,
    run_notes,
    scan_filter_of,
)
from d3dwa_bullet.io import atomic_write_bytes, atomic_write_text
from d3dwa_bullet.learning.agents.barn_record import BarnTraining
from d3dwa_bullet.method_specs import method_label
from d3dwa_bullet.resources import policies_dir as shipped_policies_dir
from d3dwa_bullet.world.registry import load_world

LEARNING_CURVE = "learning_curve.png"


@dataclass(frozen=True)
class Report:
    """Where the page went and how complete its data is."""

    path: Path
    kind: str
    done: int
    expected: int

    @property
    def complete(self) -> bool:
        return self.done == self.expected


def eval_markdown(
    rows: Sequence[dict[str, Any]],
    methods: Sequence[str],
    worlds: Sequence[str],
    seeds: Sequence[int],
    noise: str,
    title: str | None = None,
    recovery: str = "none",
    renamed: Mapping[str, str] | None = None,
    policy_notes: Sequence[str] = (),
    scan_filter: str = "none",
    barn_training: Mapping[str, BarnTraining] | None = None,
) -> str:
    """The evaluation page of ``d3dwa eval`` (table.md): success and time over training
    seeds with their intervals, then the paper's layout pooled over every episode. With a
    recovery layer the page says so under the title, each policy brought with ``--policy``
    names the config it was trained under (policy_notes, ``policy_config``), and worlds keyed
    apart from another of the same name (renamed: {key: source}, ``jobs.key_apart``) say which
    file they are; the paper track's page of distinct worlds is unchanged. BARN worlds add
    rows per split and difficulty tercile (``barn_tables``). A method that trained on BARN
    worlds (barn_training) has its line, and its cells on them a mark (``training_worlds``).
    Every line fits the page's width (``page_width``)."""
    trained = tw.trained_worlds(barn_training or {})
    mark = tw.cell_mark(trained)
    span = f"{seeds[0]}..{seeds[-1]}" if seeds else "none"
    layer = "off (the paper's stack)" if recovery == "none" else f"`{recovery}`"
    column, label = f"noise `{noise}`", conditions(worlds, noise, recovery)  # BARN's tables
    keys = "".join(
        f"World `{key}` is {source} (keyed apart from another world of that name).\n\n"
        for key, source in (renamed or {}).items()
    )
    return fit_prose(
        f"# {title or 'Evaluation: ' + world_span(worlds)}\n\n"
        f"{run_notes(recovery, policy_notes, scan_filter)}"
        f"{tw.training_lines(barn_training or {}, worlds)}"
        f"Noise profile: `{noise}`; evaluation seeds: {span}; recovery layer: {layer}.\n\n"
        f"{repeats_note(len(seeds), methods, noise)}"
        f"{keys}"
        "## Over training seeds\n\n"
        "A run is one training seed of a learned method (its episodes averaged) or one "
        "evaluation seed of a method without a policy (fixed, or the random reference). "
        "Intervals: 95 % stratified bootstrap over runs "
        "(scipy.stats.bootstrap, percentile); time is the interquartile mean of the runs' "
        f"mean time to goal; *all* averages the worlds. {score_formulas()} Each training "
        "seed's row: table_seeds.md.\n\n"
        + seed_tables(rows, methods, worlds, mark=mark)
        + "\n"
        + score_tables(rows, methods, worlds, mark)
        + floors_section(rows, methods)
        + "\n## Paper layout, pooled over every run\n\n"
        "Time [s], TL [m], PD [rad] averaged over every successful episode; T = timeout, "
        "C = collision; (k/n) where only k of n episodes succeeded; best per world and metric "
        "in bold.\n\n"
        + paper_table(rows, methods, worlds, mark)
        + barn_section(rows, methods, [column], lambda r: column, tw.group_flag(trained), label)
    )


def floors_section(rows: Sequence[dict[str, Any]], methods: Sequence[str]) -> str:
    """ "Against chance": which floor each learned method cleared, and apart from it a velocity
    planner against its reference (empty without either)."""
    return chance_sections(rows, methods)


def seeds_markdown(
    rows: Sequence[dict[str, Any]],
    methods: Sequence[str],
    worlds: Sequence[str],
    barn_training: Mapping[str, BarnTraining] | None = None,
) -> str:
    """table_seeds.md: each training seed's row (fixed methods: one row), with the line and
    marks of a method that trained on BARN worlds (see eval_markdown)."""
    training = barn_training or {}
    return fit_prose(
        f"# Per training seed: {world_span(worlds)}\n\n{tw.training_lines(training, worlds)}"
        "Cells: successes/episodes, mean time to goal of the successes; T = timeout, "
        "C = collision. Score, BARN: the mean episode score over every world (robot form, "
        "BARN's official form; docs/design/score.md#score).\n\n"
        + per_seed_table(rows, methods, worlds, tw.cell_mark(tw.trained_worlds(training)))
    )


def figure_seeds(rows: Sequence[dict[str, Any]]) -> dict[str, int | None]:
    """Per method, the training seed whose episodes the trajectory figures draw: the lowest."""
    seeds: dict[str, set[int]] = {}
    for r in rows:
        found = seeds.setdefault(r["method"], set())
        if r["policy_seed"] is not None:
            found.add(r["policy_seed"])
    return {m: min(found, default=None) for m, found in seeds.items()}


def open_results(out: str | os.PathLike[str]) -> tuple[Path, dict[str, Any], list[dict]]:
    """(directory, meta, rows of the last run's jobs) of a results directory, checked."""
    out = Path(out)
    if not out.is_dir():
        raise ResultsError(f"{out}: no such results directory")
    if not (out / "meta.json").exists() and not (out / "results.csv").exists():
        raise ResultsError(f"{out}: not a results directory (no meta.json or results.csv)")
    check_results_dir(out)
    meta = read_meta(out)
    if "jobs" not in meta or "settings" not in meta:
        raise ResultsError(f"{out / 'meta.json'}: missing 'jobs' or 'settings'")
    rows = job_rows(out, meta)
    check_not_mixed(rows, str(out / "results.csv"))
    return out, meta, rows


def _ordered(values: Sequence[Any]) -> list[Any]:
    return list(dict.fromkeys(values))


def eval_settings(meta: dict[str, Any]) -> tuple[list[str], list[str], list[int], str]:
    """(methods, worlds, seeds, noise) of an eval run, from its settings or its job list."""
    s, jobs = meta["settings"], meta["jobs"]
    methods = s.get("methods") or _ordered(j[1] for j in jobs)
    worlds = s.get("worlds") or _ordered(j[0] for j in jobs)
    seeds = s.get("seeds") or sorted({j[2] for j in jobs})
    noise = s.get("noise") or ",".join(_ordered(j[3] for j in jobs))
    return methods, worlds, seeds, noise


def write_table_page(
    results_dir: str | os.PathLike[str], dest: str | os.PathLike[str], title: str
) -> Path:
    """A complete eval directory's tables as a page at dest (atomic). ResultsError if the
    directory is incomplete: a partial table is never written as a finished one."""
    out, meta, rows = open_results(results_dir)
    done, expected = completion(out, rows)
    if done != expected:
        raise ResultsError(
            f"{out}: only {done} of {expected} episodes finished; rerun the same command to resume"
        )
    methods, worlds, seeds, noise = eval_settings(meta)
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    notes = policy_notes(out, meta)
    page = eval_markdown(
        rows, methods, worlds, seeds, noise, title, recovery_of(out), policy_notes=notes,
        scan_filter=scan_filter_of(meta), barn_training=tw.read_barn_training(out, meta),
    )  # fmt: skip
    page += f"\nFrom `{out / 'results.csv'}` ({len(rows)} episodes), d3dwa-bullet {__version__}.\n"
    atomic_write_text(dest, page)
    return dest


def learning_curves(
    out: Path, policies_dir: Path | None = None, method: str | None = None
) -> list[tuple[str, str, Path]]:
    """Copy every policies/<name>/learning_curve.png and policies/<name>/seed-<k>/
    learning_curve.png into out/figures; (name, link, source) triples, name
    "<method>/seed-<k>" for a seed's. With ``method``, policies_dir is that one method's
    folder (a ``--policy``)."""
    policies_dir = shipped_policies_dir() if policies_dir is None else policies_dir
    pattern = "" if method else "*/"
    found = (
        sorted([*policies_dir.glob(f"{pattern}{LEARNING_CURVE}"),
                *policies_dir.glob(f"{pattern}seed-*/{LEARNING_CURVE}")])
        if policies_dir.is_dir() else []
    )  # fmt: skip
    links = []
    for src in found:
        name = src.parent.relative_to(policies_dir).as_posix()
        if method:
            name = method if name == "." else f"{method}/{name}"
        dest = out / "figures" / f"learning_curve_{name.replace('/', '_')}.png"
        dest.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(dest, src.read_bytes())
        links.append((name, dest.relative_to(out).as_posix(), src))
    return links


def _image(alt: str, out: Path, path: Path) -> str:
    return f"![{alt}]({path.relative_to(out).as_posix()})\n"


def _status(done: int, expected: int, command: str) -> str:
    if done == expected:
        return f"**Complete**: all {expected} episodes finished.\n"
    resume = f" Rerun `{command}` to resume." if command else " Rerun the same command to resume."
    return (
        f"> **INCOMPLETE: {done} of {expected} episodes finished.** Tables and figures below "
        f"cover the finished episodes only and are partial.{resume}\n"
    )


def _eval_body(out: Path, meta: dict[str, Any], rows: list[dict], partial: bool) -> str:
    methods, worlds, seeds, noise = eval_settings(meta)
    note = " (PARTIAL)" if partial else ""
    recovery = meta.get("settings", {}).get("recovery", "none")
    notes = policy_notes(out, meta)
    body = eval_markdown(
        rows, methods, worlds, seeds, noise, f"Tables{note}", recovery, policy_notes=notes,
        scan_filter=scan_filter_of(meta), barn_training=tw.read_barn_training(out, meta),
    )  # fmt: skip
    body = "#" + body.replace("\n#", "\n##")  # one level down inside the page
    sources = meta["settings"].get("world_sources", worlds)
    loaded = []
    for name, src in zip(worlds, sources, strict=False):
        if not (out / "figures" / figure_name(name, "time")).exists():
            try:
                loaded.append(load_world(src))
            except Exception:  # a world file that moved: its figure is just left out
                continue
    if loaded and seeds:
        world_figures(out, loaded, methods, seeds[0], noise, figure_seeds(rows))
    figs = []
    for name in worlds:
        paths = [out / "figures" / figure_name(name, k) for k in ("time", "tau")]
        paths = [p for p in paths if p.exists()]
        if paths:
            figs.append(f"\n### {name}\n\n")
            figs.append(_image(f"{name}: trajectories coloured by elapsed time", out, paths[0]))
            for p in paths[1:]:
                figs.append("\n" + _image(f"{name}: D3DWA trajectories coloured by tau", out, p))
    if figs:
        seed_note = f"seed {seeds[0]}" if seeds else ""
        body += (
            f"\n## Trajectories{note}\n\nEvery method side by side over the map ({seed_note}), "
            "coloured by elapsed time; learned D3DWA methods also coloured by the selected "
            "horizon tau.\n" + "".join(figs)
        )
    return body


def _sweep_body(out: Path, meta: dict[str, Any], partial: bool) -> str:
    settings = SweepSettings.from_dict(meta["settings"])
    keys = {tuple(k) for k in meta["jobs"]}
    rows = once_per_layout([r for r in read_sweep(out) if row_key(r) in keys])
    # Figures newer than results.csv were drawn from these very rows: keep them.
    names = [f"sweep_{a}.png" for a in settings.axes] + ["sweep_profiles.png"] * bool(
        settings.profiles
    )
    existing = [out / "figures" / n for n in names]
    csv_time = (out / "results.csv").stat().st_mtime if (out / "results.csv").exists() else 0.0
    if not partial and all(p.exists() and p.stat().st_mtime >= csv_time for p in existing):
        figures = existing
    else:
        figures = sweep_figures(rows, settings, out / "figures", partial=partial)
    note = " (PARTIAL)" if partial else ""
    lines = [
        "## Settings\n\n",
        f"Methods: {', '.join(method_label(m) for m in settings.methods)}. "
        f"Shipped worlds: {world_span(settings.worlds)}; unseen generated layouts: "
        f"{settings.layouts} per style ({', '.join(settings.styles)}). Seeds per condition: "
        f"{settings.seeds} (from {settings.first_seed}). Levels per axis: {settings.levels} "
        "plus the shared noise-free baseline.\n\n",
        "| axis | what a level L sets | levels |\n|---|---|---|\n",
    ]
    lines += [
        f"| `{a}` | {AXES[a].sets} | 0, "
        + ", ".join(f"{v:g}" for v in AXES[a].levels(settings.levels))
        + " |\n"
        for a in settings.axes
    ]
    lines.append(f"\nProfiles: {', '.join(f'`{p}`' for p in settings.profiles)}.\n")
    lines.append(f"\n## Results{note}\n\n")
    by_name = {p.stem: p for p in figures}
    saved = meta["settings"]  # as written: it also holds what SweepSettings does not
    tables = run_notes(saved.get("recovery", "none"), policy_notes(out, meta), scan_filter_of(meta))
    tables += sweep_markdown(rows, settings, tw.read_barn_training(out, meta))
    # Put each axis's figure above its table.
    for name in [*settings.axes, "profiles"]:
        fig = by_name.get(f"sweep_{name}")
        heading = "### Named profiles" if name == "profiles" else f"(`{name}`)"
        if fig is None:
            continue
        idx = tables.find(heading)
        if idx < 0:
            continue
        end = tables.find("\n", idx) + 1
        tables = tables[:end] + "\n" + _image(f"sweep {name}", out, fig) + tables[end:]
    lines.append(tables)
    return "".join(lines)


def write_report(
    out: str | os.PathLike[str], policies_dir: str | os.PathLike[str] | None = None
) -> Report:
    """Write out/report.md for an eval or sweep results directory; returns what it wrote."""
    out, meta, rows = open_results(out)
    settings = meta["settings"]
    kind = settings.get("kind", "eval")
    done, expected = completion(out, rows)
    partial = done != expected
    command = settings.get("command", "")
    title = "Noise sweep" if kind == "sweep" else "Evaluation"
    page = [
        f"# {title}: `{out.name}`\n\n",
        _status(done, expected, command),
        f"\nd3dwa-bullet {meta.get('version', '?')}; rows from `results.csv`; "
        f"per-step logs in `logs/`.",
        f" Command: `{command}`.\n\n" if command else "\n\n",
        reused_note(settings),
    ]
    if kind == "sweep":
        page.append(_sweep_body(out, meta, partial))
    elif kind == "eval":
        page.append(_eval_body(out, meta, rows, partial))
    else:
        raise ResultsError(f"{out / 'meta.json'}: unknown results kind {kind!r}")
    # an evaluation of a --policy shows that policy's curves, not the shipped ones
    brought = settings.get("policy") if policies_dir is None else None
    if brought:
        policies, method = Path(brought), (settings.get("methods") or [None])[0]
    else:  # a --policy-root run shows its root's curves
        root = policies_dir or settings.get("policy_root")
        policies = Path(root) if root else shipped_policies_dir()
        method = None
    curves = learning_curves(out, policies, method)
    if curves:
        page.append("\n## Learning curves\n\n")
        for name, link, src in curves:
            method, _, seed = name.partition("/")
            label = method_label(method) + (f", {seed}" if seed else "")
            where = src.relative_to(policies.parent).as_posix()
            page.append(f"### {label} (`{where}`)\n\n![{name} learning curve]({link})\n\n")
    path = out / "report.md"
    atomic_write_text(path, fit_prose("".join(page)))
    return Report(path, kind, done, expected)
