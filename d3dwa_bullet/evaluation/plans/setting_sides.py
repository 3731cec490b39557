"""A plan's cells across a global-plan setting: where each side's episodes run and under what name.

A cell with ``global_plan: [A's, B's]`` (``plan_file.py``) reads method A under one ``--global-plan``
value against method B (often A itself) under another. Results with a global plan never share a
directory with results without it (``same_run.py``, the ``global_plan`` column), so ``d3dwa sweep
--plan`` runs each setting the plan's cells need into its own subdirectory of ``--out``,
``global-plan-<value>/`` (:func:`setting_dirs`: ``global-plan-scan/``, ``global-plan-none/``), each a
plain sweep directory (its meta.json, results.csv with the column as a plain ``--global-plan`` run
writes it, its lock; resumable), while the plan's own files (plan.json, looks.jsonl, looks.md)
stay in ``--out``. A cell without the field reads under the sweep's own ``--global-plan``: in
``--out`` itself when no cell has the field (a plan as before), else in that setting's
subdirectory beside the others (a plan may mix the two kinds of cell).

Each side is named by ``Cell.sides`` (its method, or ``dwa3 [global-plan scan]``);
:func:`side_source` turns a per-setting source of episodes into the one ``run.run_plan`` asks,
its rows' ``method`` relabelled to the side's name, so every estimator (``looks.ESTIMATORS``)
pairs the two sides by layout as it pairs two methods. Pure: no simulator here
(docs/design/sequential-plans.md#across-a-setting).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.evaluation.paired import Row
from d3dwa_bullet.evaluation.plans.plan_file import Plan
from d3dwa_bullet.evaluation.plans.run import Key, Source

SETTING_DIR = "global-plan-{}"
"""The subdirectory of ``--out`` holding one ``--global-plan`` setting's episodes."""
SettingRun = Callable[[str, Sequence[Key]], Sequence[Row]]
"""(a ``--global-plan`` value, (layout, profile, method) keys) -> those episodes' rows, run (or
found) under that setting."""


class Side(NamedTuple):
    """Where a cell's side runs: its ``--global-plan`` value and its method."""

    setting: str
    method: str


def plan_sides(plan: Plan, default: str) -> dict[str, Side]:
    """{side name: its Side} of every cell's sides; default: the sweep's ``--global-plan``, under
    which a cell without ``global_plan`` runs."""
    sides = {}
    for c in plan.cells:
        settings = c.global_plan or (default, default)
        for name, setting, method in zip(c.sides, settings, (c.a, c.b), strict=True):
            sides[name] = Side(setting, method)
    return sides


def setting_dirs(plan: Plan, default: str) -> dict[str, str]:
    """{``--global-plan`` value: its subdirectory of ``--out``} of every setting the plan runs, in
    the cells' order; empty when no cell has ``global_plan`` (the sweep runs in ``--out``)."""
    if not plan.global_plans:
        return {}
    settings = dict.fromkeys(s.setting for s in plan_sides(plan, default).values())
    return {s: SETTING_DIR.format(s) for s in settings}


def check_setting_options(plan: Plan, default: str, reuse: bool) -> None:
    """ConfigError (one line) for options a plan across settings cannot honour: a ``--global-plan``
    no cell would run under (every cell names its own), and ``--reuse`` (one directory's
    episodes, of one setting, for a run that writes to several)."""
    if not plan.global_plans:
        return
    where = plan.source or plan.name
    if default != "none" and all(c.global_plan for c in plan.cells):
        raise ConfigError(
            f"--global-plan {default}: every cell of the plan {where} names its sides' global plans "
            "(global_plan:); leave --global-plan out"
        )
    if reuse:
        raise ConfigError(
            f"--reuse: the plan {where} runs one directory per global-plan setting, and --reuse "
            "takes one setting's episodes; leave --reuse out"
        )


def side_source(sides: Mapping[str, Side], run: SettingRun) -> Source:
    """The source ``run.run_plan`` asks for (layout, profile, side name) keys: each key's
    episodes run under its side's setting (run(setting, (layout, profile, method) keys), once a
    setting per call), each row returned with ``method`` set to the side's name (once for each
    side asked that it stands for: two sides may be one setting's same episodes)."""

    def source(keys: Sequence[Key]) -> list[Row]:
        asked: dict[str, dict[Key, list[str]]] = defaultdict(lambda: defaultdict(list))
        for layout, profile, name in keys:
            side = sides[name]
            asked[side.setting][(layout, profile, side.method)].append(name)
        rows: list[Row] = []
        for setting, names in asked.items():
            for r in run(setting, sorted(names)):
                for name in sorted(set(names.get((r["world"], r["noise"], r["method"]), ()))):
                    rows.append({**r, "method": name})
        return rows

    return source
