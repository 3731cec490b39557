"""Pages say which BARN worlds a learned method's policy trained on, and flag results on them.

Evaluating a policy on its own training worlds is allowed, but such a result is not held out.
So when a learned method's policy (any training seed) records BARN training worlds
(``learning.agents.barn_record``), every page of the evaluation says in one line how many of
which split it trained on, each cell of a per-world table for that method on one of those worlds
carries :data:`MARK`, and a BARN split or tercile row says how many of its worlds are training
worlds (docs/design/training.md#barn-training). ``challenge`` worlds are never trained on, so a
challenge-only page has the line and no mark.

``d3dwa eval`` and ``d3dwa sweep`` read the records from the policy folders before any episode
runs and keep them in meta.json (``settings.barn_training``), so ``d3dwa report`` and ``compare``
say the same from the results directory alone. Pure: JSON only, no torch.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

from d3dwa_bullet.controllers import default_policy_path
from d3dwa_bullet.errors import CheckpointError, ResultsError
from d3dwa_bullet.evaluation.policy_runs import PolicyRun
from d3dwa_bullet.learning.agents.barn_record import (
    BarnTraining,
    barn_training,
    folder_barn_training,
)
from d3dwa_bullet.method_specs import needs_policy

MARK = "†"
"""The mark of a cell whose method trained on its world."""
SETTINGS_KEY = "barn_training"
"""meta.json ``settings`` key: {method: {"split", "ids"}} of the methods that trained on BARN."""
SHOWN_WORLDS = 5
"""Training worlds of a page named one by one in its line; more are counted."""

Trained = Mapping[str, Collection[str]]
"""Method -> the names of the worlds it trained on (``BARN-<i>``)."""


def runs_barn_training(runs: Sequence[PolicyRun]) -> dict[str, BarnTraining]:
    """Per learned method of ``runs`` whose policy folders record BARN training worlds, their
    union over its training seeds (CheckpointError, one line naming the file, for a malformed
    record)."""
    found: dict[str, BarnTraining] = {}
    for run in runs:
        if not needs_policy(run.method):
            continue
        folder = Path(run.policy) if run.policy is not None else default_policy_path(run.method)
        record = folder_barn_training(folder)
        if record is not None:
            seen = found.get(run.method)
            found[run.method] = record if seen is None else seen.union(record)
    return found


def settings_entry(training: Mapping[str, BarnTraining]) -> dict[str, dict[str, Any]]:
    """The value of meta.json ``settings.barn_training`` for ``training``."""
    return {method: record.to_dict() for method, record in training.items()}


def read_barn_training(out: Path, meta: Mapping[str, Any]) -> dict[str, BarnTraining]:
    """A results directory's ``settings.barn_training`` ({} when absent: a directory from
    before it, or no method trained on BARN); ResultsError, one line naming meta.json and the
    key, when it is malformed (a hand-edited file could hold anything)."""
    settings = meta.get("settings", {})
    entry = settings.get(SETTINGS_KEY, {}) if isinstance(settings, Mapping) else {}
    where = f"{out / 'meta.json'}: settings.{SETTINGS_KEY}"
    if not isinstance(entry, Mapping):
        raise ResultsError(f"{where} is not a mapping of method to BARN training worlds")
    try:
        return {str(m): barn_training(v, f"{where}.{m}") for m, v in entry.items()}
    except CheckpointError as err:
        raise ResultsError(str(err)) from err


def trained_worlds(training: Mapping[str, BarnTraining]) -> dict[str, frozenset[str]]:
    """Method -> the world names it trained on."""
    return {method: record.names for method, record in training.items()}


def cell_mark(trained: Trained | None) -> Callable[[str, str], str]:
    """For a table cell of ``method`` on ``world``: `` †`` when it trained there, else ''."""

    def mark(method: str, world: str) -> str:
        return f" {MARK}" if trained and world in trained.get(method, ()) else ""

    return mark


def trained_counts(trained: Trained | None, worlds: Collection[str]) -> dict[str, int]:
    """Method -> how many of a group's ``worlds`` it trained on, for each method of ``trained``
    that trained on one or more of them ({} when none did)."""
    counts = {m: sum(w in names for w in worlds) for m, names in (trained or {}).items()}
    return {m: k for m, k in counts.items() if k}


def group_count(
    trained: Trained | None, tags: Mapping[str, str] | None = None
) -> Callable[[str, Collection[str]], str]:
    """For ``method`` over a group of ``worlds``: ``k of n`` when k > 0 of them are its
    training worlds, else ''; with a tag for it (``tags``: method -> 'A', say), ``A: k of n``."""

    def count(method: str, worlds: Collection[str]) -> str:
        k = trained_counts(trained, worlds).get(method, 0)
        tag = f"{tags[method]}: " if tags and method in tags else ""
        return f"{tag}{k} of {len(worlds)}" if k else ""

    return count


def group_flag(
    trained: Trained | None, tags: Mapping[str, str] | None = None
) -> Callable[[str, Collection[str]], str]:
    """For a table row of ``method`` over a group of ``worlds`` (a BARN split or tercile):
    `` † (k of n trained on)`` when k > 0 of them are its training worlds, else ''. A row
    of two methods that both trained flags each with its tag (``tags``: method -> 'A', say):
    `` † (A: k of n trained on)``."""
    count = group_count(trained, tags)

    def flag(method: str, worlds: Collection[str]) -> str:
        said = count(method, worlds)
        return f" {MARK} ({said} trained on)" if said else ""

    return flag


def training_lines(training: Mapping[str, BarnTraining], worlds: Sequence[str]) -> str:
    """Markdown, one line per method of ``training``: how many of which split's BARN worlds it
    trained on, and which of the page's ``worlds`` are among them ('' without any method)."""
    lines = []
    for method, record in training.items():
        ours = [w for w in worlds if w in record.names]
        said = (
            f"`{method}` trained on {len(record.ids)} of BARN's {record.split_size} "
            f"{record.split} worlds (its meta.json, `metadata.barn`); "
        )
        if not ours:
            said += "none of this page's worlds is one of them."
        else:
            named = ", ".join(ours[:SHOWN_WORLDS]) + (", ..." if len(ours) > SHOWN_WORLDS else "")
            verb = "is one of them" if len(ours) == 1 else "are among them"
            said += (
                f"{len(ours)} of this page's worlds {verb} ({named}); its results there are "
                f"marked {MARK}: on a training world, not held out."
            )
        lines.append(said + "\n\n")
    return "".join(lines)
