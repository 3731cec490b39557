"""What ``d3dwa eval`` prints on the terminal for a run of many worlds: one screen, summary first.

A run of more than :data:`TERMINAL_WORLDS` worlds (BARN's 50 challenge worlds, a few hundred
generated layouts) has per-world tables a terminal cannot show: they go to table.md only, and
the terminal gets, in this order, the conditions every table shares (which worlds and BARN
split, the noise profile, the recovery layer on or off, the evaluation seeds), both score
formulas once, one row per method over every world (success, time, the robot-form score and
BARN's official one), BARN's difficulty terciles, and the floors (docs/design/cli-output.md).
A run of fewer worlds prints table.md itself, as before.

Pure: results rows in, Markdown out; no simulator, no torch.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from d3dwa_bullet.episode_metrics import BARN_CLIP, BARN_SPEED, ROBOT_CLIP, SCORE_FORM
from d3dwa_bullet.evaluation import training_worlds as tw
from d3dwa_bullet.evaluation.barn_tables import TERCILE_ORDER, split_group, tercile_group
from d3dwa_bullet.evaluation.floors import chance_sections
from d3dwa_bullet.evaluation.page_width import RIGHT, fit_prose, split_columns, world_span
from d3dwa_bullet.evaluation.score_tables import BARN, ROBOT, score_cell
from d3dwa_bullet.evaluation.scores import is_scored
from d3dwa_bullet.evaluation.seed_stats import iqm_interval
from d3dwa_bullet.evaluation.seed_tables import (
    Row,
    column_scores,
    condition_table,
    one_run_each,
    rate_cell,
    success_scores,
    time_scores,
)
from d3dwa_bullet.learning.agents.barn_record import BarnTraining
from d3dwa_bullet.method_specs import method_label
from d3dwa_bullet.world.barn import SPLIT_GROUPS

TERMINAL_WORLDS = 12
"""More worlds than this: the terminal gets the summary, the per-world tables go to table.md
(the shipped worlds, 11, still print whole)."""


def _clip(lo: float, hi: float, ref: str) -> str:
    low = ref if lo == 1 else f"{lo:g} {ref}"
    return f"clip(t, {low}, {hi:g} {ref})"


def score_formulas() -> str:
    """Both forms of the episode score in one sentence, from the constants that compute them."""
    return (
        f"Scores per episode (docs/design/score.md#score): the robot form `{SCORE_FORM}` = success x "
        f"t_ref / {_clip(*ROBOT_CLIP, 't_ref')}, t_ref = L / v_max (the robot's top speed); BARN's "
        f"official form = success x t_opt / {_clip(*BARN_CLIP, 't_opt')}, t_opt = L / "
        f"{BARN_SPEED:g} m/s; L the route's length. A run's score is its episodes' mean."
    )


def conditions(worlds: Sequence[str], noise: str, recovery: str) -> str:
    """The label every table of a run carries: its worlds (a BARN split by name), the noise
    profile and the recovery layer (``off`` on the paper's stack)."""
    splits = {split_group(w) for w in worlds}
    names = {v: k for k, v in SPLIT_GROUPS.items()}
    if None not in splits and len(splits) == 1:
        where = f"BARN {names[str(next(iter(splits)))]} split, {len(worlds)} worlds"
    else:
        where = f"{len(worlds)} worlds"
    layer = "recovery layer off" if recovery == "none" else f"recovery layer `{recovery}`"
    return f"{where}; noise `{noise}`; {layer}"


def _runs(rows: Sequence[Row]) -> str:
    seeds = {r["policy_seed"] for r in rows if r["policy_seed"] is not None}
    if seeds:
        return f"{len(seeds)} training seed{'s' * (len(seeds) != 1)}"
    evals = {r["seed"] for r in rows}
    return f"{len(evals)} evaluation seed{'s' * (len(evals) != 1)}"


def overall_table(rows: Sequence[Row], methods: Sequence[str]) -> str:
    """One row per method over every world: success [%], IQM time to goal [s], the robot-form
    score and BARN's official score, each the mean over worlds with its 95 % interval over
    runs (the value alone where every world has one run)."""
    header = ["Method", "runs", "success [%]", "time to goal, IQM [s]", f"score ({SCORE_FORM})",
              "BARN's official score"]  # fmt: skip
    body = []
    scored = is_scored(rows)
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        if not mine:
            continue
        by_world: dict[str, list[Row]] = {}
        for r in mine:
            by_world.setdefault(r["world"], []).append(r)
        per = list(by_world.values())
        times = [t for t in (time_scores(rs) for rs in per) if t]
        time = score_cell(times, iqm_interval, digits=1) if times else "--"
        robot = score_cell([column_scores(rs, ROBOT) for rs in per]) if scored else "--"
        barn = score_cell([column_scores(rs, BARN) for rs in per], digits=3) if scored else "--"
        body.append([method_label(m), _runs(mine), rate_cell([success_scores(rs) for rs in per]),
                     time, robot, barn])  # fmt: skip
    return split_columns(header, ["---", "---", *[RIGHT] * 4], body)


def eval_summary(
    rows: Sequence[Row],
    methods: Sequence[str],
    worlds: Sequence[str],
    seeds: Sequence[int],
    noise: str,
    recovery: str = "none",
    barn_training: Mapping[str, BarnTraining] | None = None,
) -> str:
    """The terminal's page of a run of many worlds (module docstring), every line within the
    page's width."""
    label = conditions(worlds, noise, recovery)
    span = f"{seeds[0]}..{seeds[-1]}" if seeds else "none"
    cells: dict[tuple[str, str], list[Row]] = {}
    for r in rows:
        cells.setdefault((r["method"], r["world"]), []).append(r)
    one_run = one_run_each([success_scores(rs) for rs in cells.values()])
    runs_note = (
        " Every method has one run a world here, so no cell has an interval." if one_run else ""
    )
    parts = [
        f"# Evaluation: {world_span(worlds)}\n\n"
        f"Every table: {label}; evaluation seeds {span}.\n\n"
        f"{tw.training_lines(barn_training or {}, worlds)}"
        f"{score_formulas()}\n\n"
        f"## Over every world ({label})\n\n"
        "Mean over worlds, 95 % stratified bootstrap interval over runs (a learned method's "
        f"training seeds, another method's evaluation seeds).{runs_note}\n\n",
        overall_table(rows, methods),
    ]
    terciles = [g for g in TERCILE_ORDER if any(tercile_group(w) == g for w in worlds)]
    if terciles:
        flag = tw.group_flag(tw.trained_worlds(barn_training or {}))
        column = f"success [%], noise `{noise}`"
        parts.append(
            f"\n## BARN by difficulty tercile ({label})\n\n"
            + condition_table(
                [r for r in rows if tercile_group(r["world"])],
                methods,
                [column],
                lambda r: column,
                terciles,
                lambda r: str(tercile_group(r["world"])),
                flag=flag,
            )  # fmt: skip
        )
    parts.append(chance_sections(rows, methods))
    return fit_prose("".join(parts))
