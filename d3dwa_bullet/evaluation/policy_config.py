"""Which config a policy brought with ``--policy`` was trained under, said on the page.

Users bring their own policies: a folder trained under another config than its method's
committed ``configs/<method>.yaml`` still runs, and the evaluation page names that config and
how it differs, so a table never passes another learner's seeds off as the method's. A policy
trained inside a recovery layer that the evaluation runs without (or the reverse) is said too.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import CheckpointError, D3DWAError
from d3dwa_bullet.evaluation.policy_runs import PolicyRun
from d3dwa_bullet.evaluation.same_run import differences
from d3dwa_bullet.learning.agents.policy_terms import checkpoint_terms
from d3dwa_bullet.learning.training.config import TrainConfig, load_train_config
from d3dwa_bullet.limits import MAX_NOTE_CHARS, MAX_NOTE_VALUE_CHARS, cut_text
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.resources import configs_dir

SHOWN = 6
"""Differences named on the page (top-level fields first); the rest are counted."""

IGNORED = ("seed", "agent.seed")
"""Fields that differ between the seeds of one experiment."""

BOOKKEEPING = ("checkpoint_every", "eval_every", "log_every", "eval_worlds", "eval_seeds")
"""Fields that do not change what is learned: named after those that do."""


def _plain(config: TrainConfig) -> dict[str, Any]:
    data = config.to_dict()
    for name in IGNORED:
        *parent, leaf = name.split(".")
        (data[parent[0]] if parent else data).pop(leaf, None)
    return data


def _order(name: str) -> tuple[bool, bool, str]:
    return (name in BOOKKEEPING, "." in name, name)


def _value(value: Any) -> str:
    return "unset" if value is None else cut_text(str(value), MAX_NOTE_VALUE_CHARS)


def policy_config_note(run: PolicyRun, recovery: str, policy: str | None) -> str | None:
    """One Markdown line on the config ``run``'s policy folder was trained under, against
    its method's committed config (``policy``: the ``--policy`` it came from); None when the
    run has no policy folder with a config.json (a fixed method, a bare checkpoint). A
    config.json that does not read as a training config (another version's, say) does not
    stop the run: the line says so instead. A shipped policy (``policy`` None) was trained
    under the committed config (tests/learning/test_shipped_policies.py): its line only
    says when it trained inside a recovery layer this evaluation runs without, or the reverse."""
    if run.policy is None:
        return None
    config_file = Path(run.policy) / "config.json"
    if not config_file.is_file():
        return None
    if policy is None:  # the layer its meta.json records: no config to build at start-up
        meta_file = Path(run.policy) / "meta.json"
        _, trained_in, _ = checkpoint_terms(load_json(meta_file, CheckpointError), str(meta_file))
        layer = _layer(trained_in, recovery)
        shipped = f"The shipped `{run.method}`: trained under `configs/{run.method}.yaml`."
        return f"{shipped}{layer}" if layer else None
    source = f"`{run.method}` from `{policy}`"
    try:
        data = load_json(config_file, CheckpointError)
        trained = TrainConfig.from_dict(data, str(config_file))
    except D3DWAError as err:
        return f"{source}: its config could not be read as a training config ({err})."
    committed = load_train_config(configs_dir() / f"{run.method}.yaml")
    diffs = sorted(differences(_plain(committed), _plain(trained)), key=lambda d: _order(d[0]))
    if not diffs:
        line = f"{source}: trained under the committed `configs/{run.method}.yaml`."
    else:
        named = ", ".join(
            f"{k} {_value(new)} (committed {_value(old)})" for k, old, new in diffs[:SHOWN]
        )
        more = f" and {len(diffs) - SHOWN} more" if len(diffs) > SHOWN else ""
        line = (
            f"{source}: trained under its own config (`{config_file}`), not the committed "
            f"`configs/{run.method}.yaml`: {named}{more}."
        )
    return line + _layer(trained.recovery, recovery)


def _layer(trained: str, recovery: str) -> str:
    """The sentence on a recovery layer the policy trained in and this evaluation does not
    run (or the reverse); '' when they agree."""
    if trained == recovery:
        return ""
    return f" It was trained with the recovery layer `{trained}`; this evaluation runs with `{recovery}`."


def policy_config_notes(runs: Sequence[PolicyRun], recovery: str, policy: str | None) -> list[str]:
    """:func:`policy_config_note` for the first training seed of each learned method, brought
    with ``--policy`` or shipped (the seeds of one method share their config:
    ``policy_runs`` checks). Values copied from a user's config.json are cut to
    ``MAX_NOTE_VALUE_CHARS``, a whole note to ``MAX_NOTE_CHARS`` (a mark says so)."""
    notes, seen = [], set()
    for run in runs:
        if run.method in seen:
            continue
        note = policy_config_note(run, recovery, policy)
        if note is not None:
            seen.add(run.method)
            notes.append(cut_text(note, MAX_NOTE_CHARS))
    return notes
