"""Which policies an evaluation runs: every shipped training seed of each learned method.

A learned method's result is its distribution over training seeds
(docs/design/learning-protocol.md#learning-protocol), so an evaluation drives every ``seed-<k>/`` of the
method's policy folder (``policies/<method>/``, ``DIR/<method>/`` under ``--policy-root DIR``,
or ``--policy DIR``: :func:`policy_folder`) unless ``--policy-seeds`` names some of them: the
same seeds of every learned method (``0-4``), or per method (``d3dwa=0-14;d3dwa-dr=0-4``, a
method not named runs all of its seeds: what a sequential plan's ``seeds`` field becomes,
``plans/plan_seeds.py``). A folder without seed folders is one policy (a
checkpoint, or one ``seed-<k>`` folder given as ``--policy``). A fixed or reference method
(``random``) is one run with no policy.

The seeds of one method must be one experiment: trained under the same config (all but
the seed), the same action set and the same recorded terms (``policy_terms.folder_terms``); a folder mixing configs is refused, naming both seeds
and what differs. :func:`policy_digests` names the weights each run drives, so that a
resumed evaluation can refuse rows driven by other weights (a policy folder replaced by
new training).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from d3dwa_bullet.controllers import default_policy_path, one_policy
from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.evaluation.same_run import differences
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.loading import load_json
from d3dwa_bullet.method_specs import needs_policy
from d3dwa_bullet.planning.scan_filter import check_driven_filter
from d3dwa_bullet.seed_dirs import parse_seeds, seed_dirs, seed_of
from d3dwa_bullet.world.barn import barn_split_ids

ALL = "all"
POLICY_DATA_FILES = ("weights.pt", "table.npy")
"""The file that holds a policy's parameters (D3QN, DQDWA); its SHA-256 is in meta.json."""


@dataclass(frozen=True)
class PolicyRun:
    """One trained (or fixed, or reference) controller to evaluate."""

    method: str
    policy_seed: int | None = None
    """The training seed (``seed-<k>``), None for a method without a policy or a single one."""
    policy: str | None = None
    """The policy folder to load; None for a method without a policy or its shipped one."""


LATER_CONFIG_KEYS: dict[str, Any] = {
    "barn_split": "none",
    "barn_worlds": len(barn_split_ids("train")),
    "scan_filter": "none",
    "init_policy": None,
}
"""Training-config keys added after the shipped seeds trained, each with the value that trains as
before they existed (``TrainConfig``'s defaults; a test holds them equal): a config.json
without one was trained under that value, so seeds trained before and after the key was added
are one experiment when the later ones kept it (issue 79's seeds 5-9 beside the shipped 0-4)."""


def _experiment(folder: Path) -> dict[str, Any]:
    """What must agree between the seeds of one method: the config without its seeds, and
    the action set."""
    found: dict[str, Any] = {}
    for name in ("config.json", "meta.json"):
        path = folder / name
        if not path.is_file():
            continue
        data = load_json(path, CheckpointError)
        if not isinstance(data, dict):
            raise CheckpointError(f"{path}: expected a JSON object, got {type(data).__name__}")
        if name == "config.json":
            data.pop("seed", None)
            data = LATER_CONFIG_KEYS | data
            if isinstance(data.get("agent"), dict):
                data["agent"] = {k: v for k, v in data["agent"].items() if k != "seed"}
            found["config"] = data
        else:
            found["actions"] = data.get("actions")
            found["terms"] = folder_terms(folder)  # meta.json's, checked against config.json
    return found


def check_one_experiment(folder: Path, seeds: dict[int, Path]) -> None:
    """CheckpointError unless every seed folder was trained under one config and action set,
    and records the same terms (decision period, recovery, observation) in its meta.json."""
    items = list(seeds.items())
    if not items:
        return
    first, first_dir = items[0]
    reference = _experiment(first_dir)
    for k, path in items[1:]:
        diffs = [
            f"{name} {a!r} vs {b!r}" for name, a, b in differences(reference, _experiment(path))
        ]
        if diffs:
            shown = "; ".join(diffs[:3]) + ("; ..." if len(diffs) > 3 else "")
            raise CheckpointError(
                f"{folder}: seed-{k} was trained under another config or action set than "
                f"seed-{first} ({shown}); the seeds of one method must be one experiment"
            )


def policy_folder(method: str, policy: str | None = None, policy_root: str | None = None) -> Path:
    """The folder of a learned method's policies: ``policy`` (``--policy``), else
    ``policy_root/<method>/`` (``--policy-root``), else the shipped ``policies/<method>/``;
    what an evaluation drives and a plan's seeds are counted in."""
    return Path(policy) if policy is not None else default_policy_path(method, policy_root)


def per_method_seeds(spec: str | None) -> dict[str, str] | None:
    """{method: its seeds} of a per-method ``--policy-seeds`` ('d3dwa=0-14;d3dwa-dr=0,1'); None
    for a spec of every method ('all', '0-4'). ConfigError naming a part that is not
    method=seeds, or a method named twice."""
    if spec is None or "=" not in spec:
        return None
    found: dict[str, str] = {}
    for part in spec.split(";"):
        name, sep, seeds = (x.strip() for x in part.partition("="))
        if not (sep and name and seeds):
            raise ConfigError(
                f"--policy-seeds: {part!r} in {spec!r} is not method=seeds (like d3dwa=0-4)"
            )
        if name in found:
            raise ConfigError(f"--policy-seeds: {spec!r} names {name} twice")
        found[name] = seeds
    return found


def select_seeds(folder: Path, spec: str | None) -> dict[int, Path]:
    """The seed folders of folder named by spec ('all' or None: every one; '0,2', '0-3')."""
    shipped = seed_dirs(folder)
    if spec is None or spec.strip() == ALL:
        return shipped
    wanted = parse_seeds(spec, "--policy-seeds")
    missing = [k for k in wanted if k not in shipped]
    if missing:
        have = ", ".join(f"seed-{k}" for k in shipped) or "no seed folders"
        raise ConfigError(f"--policy-seeds: {folder} has no seed-{missing[0]} (it has {have})")
    return {k: shipped[k] for k in wanted}


def check_policy_root(
    root: str | None, methods: Sequence[str], policy: str | None = None
) -> str | None:
    """``--policy-root DIR`` checked before any episode (ConfigError, one line): not beside
    ``--policy``, DIR a folder, and holding ``DIR/<method>/`` for every learned method of
    ``methods``. Returns DIR resolved (what meta.json records); None without the option."""
    if root is None:
        return None
    if policy is not None:
        raise ConfigError(
            f"--policy-root {root} and --policy {policy} both say where policies are: give one"
        )
    folder = Path(root)
    if not folder.is_dir():
        raise ConfigError(f"--policy-root {root}: no such folder")
    for method in methods:
        if needs_policy(method) and not default_policy_path(method, folder).is_dir():
            raise ConfigError(
                f"--policy-root {root}: it has no folder {method}/ for learned method {method!r} "
                f"(expected {default_policy_path(method, folder)}/seed-<k>/)"
            )
    return str(folder.resolve())


def method_runs(
    methods: Sequence[str],
    policy: str | None = None,
    policy_seeds: str | None = None,
    policy_root: str | None = None,
) -> list[PolicyRun]:
    """The runs of each method, in method order then seed order (module docstring).

    policy: ``--policy`` (one learned method only; the caller checks). policy_seeds:
    ``--policy-seeds``, for every learned method or per method (:func:`per_method_seeds`);
    ConfigError if it names a seed some learned method's folder lacks, a method that is not a
    learned one here, or if no method has seed folders to choose from. policy_root:
    ``--policy-root`` (checked by :func:`check_policy_root`), where each learned method's
    folder is instead of the shipped ``policies/``; its runs name their folders."""
    runs: list[PolicyRun] = []
    chosen = False
    per_method = per_method_seeds(policy_seeds)
    for name in per_method or ():
        if name not in methods or not needs_policy(name):
            raise ConfigError(
                f"--policy-seeds: {name} is not a learned method of this run ({', '.join(methods)})"
            )
    for method in methods:
        if not needs_policy(method):
            runs.append(PolicyRun(method))
            continue
        folder = policy_folder(method, policy, policy_root)
        seeds = seed_dirs(folder)
        if not seeds:  # one policy: a checkpoint, a seed-<k> folder, or an old shipped one
            named = str(folder) if policy_root is not None and policy is None else policy
            runs.append(PolicyRun(method, seed_of(folder) if policy is not None else None, named))
            continue
        chosen = True
        selected = select_seeds(
            folder, policy_seeds if per_method is None else per_method.get(method, ALL)
        )
        check_one_experiment(folder, selected)
        runs += [PolicyRun(method, k, str(path)) for k, path in selected.items()]
    if policy_seeds is not None and policy_seeds.strip() != ALL and not chosen:
        raise ConfigError(
            f"--policy-seeds {policy_seeds}: no learned method here has seed-<k> folders "
            "to choose from"
        )
    return runs


def policy_digests(runs: Sequence[PolicyRun]) -> dict[str, str]:
    """Per learned run, ``<method>`` or ``<method>/seed-<k>``: the SHA-256 of its weights
    (or Q-table) as its meta.json records it ('' if the folder has none)."""
    digests = {}
    for run in runs:
        if not needs_policy(run.method):
            continue
        folder = policy_folder(run.method, run.policy)
        name = run.method if run.policy_seed is None else f"{run.method}/seed-{run.policy_seed}"
        digests[name] = _data_digest(folder)
    return digests


def _data_digest(folder: Path) -> str:
    try:
        files = load_json(folder / "meta.json", CheckpointError).get("files", {})
    except (CheckpointError, AttributeError):
        return ""
    entry = next(
        (files[f] for f in POLICY_DATA_FILES if isinstance(files, dict) and f in files), {}
    )
    return str(entry.get("sha256", "")) if isinstance(entry, dict) else ""


def check_scan_filters(policies: Iterable[tuple[str, str | None]], scan_filter: str) -> None:
    """ConfigError (one line) before any episode runs if a (method, policy folder) of
    ``policies`` (None: the shipped one) was trained behind a scan filter other than this
    run's ``scan_filter`` (``check_driven_filter``); a policy trained without one runs behind
    any. Read with ``folder_terms``, once per folder."""
    seen: set[tuple[str, str | None]] = set()
    for method, policy in policies:
        if not needs_policy(method) or (method, policy) in seen:
            continue
        seen.add((method, policy))
        folder, _ = one_policy(method, policy)
        if not (folder / "meta.json").is_file():  # a bare Q-table: its loader says what it lacks
            continue
        trained = folder_terms(folder)["scan_filter"]
        check_driven_filter(str(trained), scan_filter, f"{method} ({folder})")
