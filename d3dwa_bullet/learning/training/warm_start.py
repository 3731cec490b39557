"""A run that starts from a trained policy's network: ``TrainConfig.init_policy``.

Beyond the paper, off by default (docs/noise.md#recipe-6). The second stage of a two-stage
noise curriculum: ``d3dwa``'s noise-free training is the first, and a randomised run picks up
its network. Only the network's weights carry over (online and target); the optimiser, the
replay buffer, exploration and the episode sequence start fresh from the run's own seed, so
a warm-started run is as reproducible as any other.

``init_policy`` names a folder of training seeds (``seed-<k>/``: the run's own seed ``k``
is taken) or one policy folder; a bare name with no such folder here is a shipped method's
policies (``d3dwa`` -> the install's ``policies/d3dwa``). ``source`` resolves and checks it
when a run starts, before any work: a D3QN of the run's action set, observation, network,
decision period, recovery layer and scan filter, or ConfigError naming the field and what
differs (a network trained on unfiltered scans would start a run behind a filter with inputs
it never saw, and the run's record would not say so).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from d3dwa_bullet.errors import CheckpointError, ConfigError, InstallError
from d3dwa_bullet.learning.agents.checkpoint_load import load_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.policy_terms import folder_terms
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.seed_dirs import seed_dir

if TYPE_CHECKING:  # the config's module imports the training package
    from d3dwa_bullet.learning.training.config import TrainConfig

FIELD = "TrainConfig.init_policy"


class WarmStart(NamedTuple):
    """The network a run starts from, and where it came from (recorded in run.json)."""

    folder: Path
    agent: D3QNAgent

    def record(self) -> dict[str, Any]:
        weights = self.folder / "weights.pt"
        digest = hashlib.sha256(weights.read_bytes()).hexdigest() if weights.is_file() else None
        return {"folder": str(self.folder), "weights_sha256": digest}


def _folder(name: str, seed: int) -> Path:
    """The policy folder ``name`` means for a run of ``seed`` (module docstring)."""
    given = Path(name)
    candidates = [given]
    if len(given.parts) == 1 and not given.exists():
        try:
            candidates.append(policies_dir() / name)
        except InstallError:
            pass
    for base in candidates:
        if (seed_dir(base, seed) / "meta.json").is_file():
            return seed_dir(base, seed)
        if (base / "meta.json").is_file():
            return base
    raise ConfigError(
        f"{FIELD}: {name!r} is neither a policy folder nor a folder of seeds holding "
        f"seed-{seed}/ (looked in {', '.join(str(c) for c in candidates)})"
    )


def source(config: TrainConfig) -> WarmStart | None:
    """The checked network ``config.init_policy`` names for this run; None when it names none.

    ConfigError naming ``init_policy`` when the folder is missing, unreadable, a tabular
    policy, or differs from the run in action set, observation, hidden layers, decision
    period, recovery layer or scan filter."""
    if config.init_policy is None:
        return None
    folder = _folder(config.init_policy, config.seed)
    try:
        agent, _ = load_checkpoint(
            folder,
            expected_actions=config.actions,
            expected_layout=config.obs_layout,
            reader=f"this run ({config.method})",
        )
        terms = folder_terms(folder)
    except CheckpointError as err:
        raise ConfigError(f"{FIELD}: {err}") from err
    if not isinstance(agent, D3QNAgent) or config.family != "d3qn":
        raise ConfigError(f"{FIELD}: {folder} is not a D3QN policy of a D3QN method's run")
    run_terms: dict[str, object] = {
        "decision_steps": config.decision_steps,
        "recovery": config.recovery,
        "scan_filter": config.scan_filter,
    }
    run_terms["hidden"] = list(config.agent.hidden)  # type: ignore[union-attr]
    have = {**terms, "hidden": list(agent.config.hidden)}
    for term, want in run_terms.items():
        if have[term] != want:
            raise ConfigError(
                f"{FIELD}: {folder} was trained with {term} {have[term]!r}, this run has {want!r}"
            )
    return WarmStart(folder, agent)


def apply(agent: D3QNAgent, start: WarmStart) -> None:
    """Load ``start``'s network into ``agent``'s online and target networks."""
    agent.load_state_dict(start.agent.state_dict())
