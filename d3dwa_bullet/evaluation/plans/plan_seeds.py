"""A plan's training seeds: each listed method's N lowest-numbered seed folders, or a refusal.

A plan's ``seeds: {method: N}`` (``plan_file.py``) fixes before any episode how many training
seeds each learned method brings; which ones is fixed too, never chosen by results: the N
lowest-numbered ``seed-<k>/`` folders of the method's policy folder, found where the sweep finds
its policies (``policy_runs.policy_folder``). :func:`with_plan_seeds` turns them into the sweep's
``--policy-seeds`` (the per-method form ``d3dwa=0,1,2;d3dwa-dr=0,1``), so the sweep runs those
seeds and no other, and meta.json records them. A folder holding fewer is refused in one line
saying how many it has and how many the plan needs (docs/design/sequential-plans.md#seeds).
:func:`plan_seed_rows` keeps a finished sweep's rows to the same seeds (a plan replayed on it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.evaluation.plans.plan_file import Plan
from d3dwa_bullet.evaluation.policy_runs import ALL, policy_folder
from d3dwa_bullet.evaluation.sweep_settings import SweepSettings
from d3dwa_bullet.seed_dirs import seed_dirs


def plan_seed_spec(
    plan: Plan, policy: str | None = None, policy_root: str | None = None
) -> str | None:
    """The per-method ``--policy-seeds`` of the plan's ``seeds`` (each method's N lowest seed
    folders), None for a plan without ``seeds``. ConfigError naming the method, its folder,
    the seeds it has and the seeds the plan needs when a folder holds fewer."""
    if not plan.seeds:
        return None
    parts = []
    for method, n in plan.seeds.items():
        folder = policy_folder(method, policy, policy_root)
        have = list(seed_dirs(folder))
        if len(have) < n:
            raise ConfigError(
                f"plan {plan.source or plan.name}: {method} has {len(have)} training seeds ({folder}), "
                f"the plan needs {n}"
            )
        parts.append(f"{method}={','.join(str(k) for k in have[:n])}")
    return ";".join(parts)


def with_plan_seeds(
    settings: SweepSettings, plan: Plan, policy: str | None = None
) -> SweepSettings:
    """settings whose ``policy_seeds`` are the plan's (:func:`plan_seed_spec`); unchanged for a
    plan without ``seeds``. ConfigError when ``--policy-seeds`` names other seeds as well."""
    spec = plan_seed_spec(plan, policy, settings.policy_root)
    if spec is None or settings.policy_seeds == spec:
        return settings
    if settings.policy_seeds.strip() != ALL:
        raise ConfigError(
            f"--policy-seeds {settings.policy_seeds}: the plan {plan.source or plan.name} names its training "
            "seeds (seeds:); leave --policy-seeds out"
        )
    return replace(settings, policy_seeds=spec)


def plan_seed_rows(rows: Sequence[Mapping[str, Any]], plan: Plan) -> list[Mapping[str, Any]]:
    """rows (each with "method" and "policy_seed") with every method of the plan's ``seeds``
    kept to its N lowest-numbered training seeds among them, the others as they are; ResultsError
    naming the method, the seeds the rows hold and the seeds the plan needs when they hold fewer."""
    keep = {}
    for method, n in plan.seeds.items():
        have = sorted(
            {
                int(r["policy_seed"])
                for r in rows
                if r["method"] == method and r.get("policy_seed") is not None
            }
        )
        if len(have) < n:
            raise ResultsError(
                f"plan {plan.source or plan.name}: the rows hold {len(have)} training seeds of {method}, the plan needs {n}"
            )
        keep[method] = set(have[:n])
    return [r for r in rows if r["method"] not in keep or r.get("policy_seed") in keep[r["method"]]]
