"""Does a policy directory's learner value its own greedy episodes as they pay? Do its seeds agree?

    python -m tools.experiments.value_check policies/d3dwa            # every seed-<k>/ inside
    python -m tools.experiments.value_check runs/d3dwa/seed-0 --json  # one policy
    python -m tools.experiments.value_check DIR --episodes            # + a row per episode
    python -m tools.experiments.value_check DIR --epsilon 0.05        # acting as in training
    python -m tools.experiments.value_check DIR --worlds validation   # its config's eval_worlds

Each seed's greedy policy runs one noise-free episode on each of R1-R3 and three fresh
generated layouts (generator seeds 2^31 + 1000, never drawn in training or by the sweep's
first layouts), scored by the training env's own reward at the seed's ``reward_scale``. Per seed
it prints the value calibration (docs/design/agent.md#value-calibration): the mean Q(s, a) of the
visited pairs against the discounted return they earned, at the seed's own gamma, with the
ratio (or, where the mean return is under 0.1 in magnitude, the gap) and the verdict, pooled
and split into the episodes that reached the goal and the rest (a stall valued as if the goal
were near shows there). Then,
over every state any seed visited, how often two seeds pick the same greedy action (chance is
1 / |actions| for unrelated choosers), and the median gap between a state's best and second
best Q. Nothing is selected by it: it is a diagnostic, not a checkpoint rule.
"""

from __future__ import annotations

import itertools
import json
import sys
from pathlib import Path
from typing import Any, cast

import numpy as np
from gymnasium.spaces import Discrete

from d3dwa_bullet.errors import ConfigError, D3DWAError
from d3dwa_bullet.evaluation.page_width import fit_prose
from d3dwa_bullet.learning.agents.checkpoint import META_FILE, load_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.policy import (
    Policy,
    all_q_values,
    greedy_policy,
    taken_q_values,
)
from d3dwa_bullet.learning.tasks import resolve_world
from d3dwa_bullet.learning.training import load_train_config
from d3dwa_bullet.learning.training.config import make_env
from d3dwa_bullet.learning.training.greedy_eval import GreedyEpisode, greedy_episode
from d3dwa_bullet.learning.value_calibration import calibrate, calibrate_by_outcome
from d3dwa_bullet.seed_dirs import seed_dirs
from d3dwa_bullet.world.generator import UNSEEN_LAYOUT_SEED_BASE
from tools.entry import ToolParser, fail, tool_main

LAYOUT_SEED = UNSEEN_LAYOUT_SEED_BASE + 1000
WORLDS = ("R1", "R2", "R3", *(f"{s}-style-s{LAYOUT_SEED}" for s in ("R1", "R2", "R3")))


VALIDATION = "validation"
"""``--worlds validation``: the eval_worlds of each seed's own config (its greedy validation
layouts, the ones its training logged value ratios on)."""


class NoPolicyError(D3DWAError, ValueError):
    """A directory with neither a policy nor seed-<k>/ policies in it."""


def policy_dirs(path: Path) -> dict[str, Path]:
    """label -> policy folder: the folder itself, or each of its seed-<k>/ folders."""
    if (path / META_FILE).is_file():
        return {path.name: path}
    seeds = {f"seed-{k}": p for k, p in seed_dirs(path).items() if (p / META_FILE).is_file()}
    if not seeds:
        raise NoPolicyError(
            f"{path}: no policy here (no {META_FILE}, no seed-<k>/{META_FILE}); give a policy "
            "directory such as policies/d3dwa"
        )
    return seeds


def load(path: Path) -> tuple[D3QNAgent | DQDWAAgent, Any]:
    """The agent of a policy folder and the training config beside it."""
    config = load_train_config(path / "config.json")
    agent, _ = load_checkpoint(path, expected_layout=config.obs_layout, reader=str(path))
    return agent, config  # type: ignore[return-value]


def epsilon_greedy(policy: Policy, n_actions: int, epsilon: float, seed: int) -> Policy:
    """``policy`` but a uniform action with probability ``epsilon`` (its own seeded stream)."""
    rng = np.random.default_rng(seed)

    def act(obs: np.ndarray) -> int:
        if rng.random() < epsilon:
            return int(rng.integers(n_actions))
        return int(policy(obs))

    return act


def episodes_of(
    agent: D3QNAgent | DQDWAAgent,
    config: Any,
    epsilon: float = 0.0,
    worlds: tuple[str, ...] = WORLDS,
) -> list[GreedyEpisode]:
    env = make_env(config, worlds=worlds, allow_eval_worlds=True)
    policy = greedy_policy(agent)
    if epsilon:
        policy = epsilon_greedy(policy, int(cast(Discrete, env.action_space).n), epsilon, seed=0)
    try:
        return [greedy_episode(env, policy, w, "none", 0) for w in worlds]
    finally:
        env.close()


def episode_worlds(folder: Path, config: Any, worlds: tuple[str, ...]) -> tuple[str, ...]:
    """The worlds one policy's episodes run on: ``worlds``, or for ``--worlds validation`` its
    config's eval_worlds, each resolved (ConfigError / WorldFormatError before any episode)."""
    if worlds != (VALIDATION,):
        return worlds
    source = f"{folder / 'config.json'}: eval_worlds"
    where = tuple(config.eval_worlds)
    if not where:
        raise ConfigError(
            f"{source} is empty, so --worlds {VALIDATION} has no world to run; name the worlds "
            "with --worlds"
        )
    for world in where:
        resolve_world(world, allow_eval_worlds=True, where=source)
    return where


def check(path: Path, epsilon: float = 0.0, worlds: tuple[str, ...] = WORLDS) -> dict[str, Any]:
    """Every figure of the module docstring for one policy directory (``epsilon`` > 0: the
    episodes act epsilon-greedily instead, a diagnostic of whose returns the values follow;
    ``worlds``: other worlds than R1-R3 and three fresh layouts, e.g. the training worlds)."""
    folders = policy_dirs(path)
    agents = {label: load(p) for label, p in folders.items()}
    plan = {label: episode_worlds(folders[label], c, worlds) for label, (_, c) in agents.items()}
    seeds, states = [], []
    for label, (agent, config) in agents.items():  # every check passed: progress from here
        print(f"value_check: {label}: {len(plan[label])} greedy episodes", file=sys.stderr)
        eps = episodes_of(agent, config, epsilon, plan[label])
        gamma = agent.config.gamma
        q_taken = [taken_q_values(agent, e.obs, e.actions) for e in eps]
        rewards = [e.rewards for e in eps]
        cal = calibrate(q_taken, rewards, gamma)
        by_outcome = calibrate_by_outcome(q_taken, rewards, [e.outcome for e in eps], gamma)
        states.append(np.concatenate([e.obs for e in eps]))
        seeds.append({
            "policy": label, "gamma": agent.config.gamma,
            "outcomes": {e.world: e.outcome for e in eps}, **cal.to_dict(),
            "judged_by": cal.judged_by,
            "by_outcome": {k: {**c.to_dict(), "judged_by": c.judged_by}
                           for k, c in by_outcome.items()},
            "episodes_detail": [
                {"world": e.world, "outcome": e.outcome, "seconds": e.seconds,
                 "decisions": len(q), **calibrate([q], [e.rewards], gamma).to_dict()}
                for e, q in zip(eps, q_taken, strict=True)
            ],
        })  # fmt: skip
    visited = np.concatenate(states)
    tables = {label: all_q_values(agent, visited) for label, (agent, _) in agents.items()}
    greedy = {label: t.argmax(axis=1) for label, t in tables.items()}
    pairs = [float(np.mean(greedy[a] == greedy[b])) for a, b in itertools.combinations(greedy, 2)]
    n_actions = next(iter(tables.values())).shape[1]
    gaps = {}
    for label, t in tables.items():
        top2 = np.sort(t, axis=1)[:, -2:]
        gaps[label] = float(np.median(top2[:, 1] - top2[:, 0]))
    return {
        "directory": str(path),
        "worlds": list(worlds),
        "epsilon": epsilon,
        "seeds": seeds,
        "states": len(visited),
        "agreement": float(np.mean(pairs)) if pairs else None,
        "agreement_pairs": len(pairs),
        "chance": 1.0 / n_actions,
        "median_best_gap": gaps,
    }


def describe_episodes(result: dict[str, Any]) -> str:
    """One row per greedy episode: where a seed's values track and where they miss."""
    lines = [
        "| policy | world | outcome | s | decisions | mean Q | discounted return | ratio |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for s in result["seeds"]:
        for e in s["episodes_detail"]:
            lines.append(
                f"| {s['policy']} | {e['world']} | {e['outcome']} | {e['seconds']:.1f} "
                f"| {e['decisions']} | {e['mean_q']:.3f} | {e['mean_return']:.3f} "
                f"| {_ratio_text(e['ratio'])} |"
            )
    return "\n".join(lines)


def _ratio_text(ratio: float | None) -> str:
    return "--" if ratio is None else f"{ratio:.2f}"


def _verdict(calibration: dict[str, Any]) -> str:
    return f"{'yes' if calibration['calibrated'] else 'NO'} ({calibration['judged_by']})"


def _acting(result: dict[str, Any]) -> str:
    eps = result.get("epsilon", 0.0)
    return f"epsilon-greedy ({eps:g})" if eps else "greedy"


def describe(result: dict[str, Any]) -> str:
    lines = [
        fit_prose(
            f"{result['directory']}: {_acting(result)} episodes on {', '.join(result['worlds'])}, "
            "no noise"
        ),
        "| policy | gamma | goals | mean Q | discounted return | ratio | gap | tracks? "
        "| best - 2nd best Q (median) |",
        "|---|---:|---:|---:|---:|---:|---:|---|---:|",
    ]
    for s in result["seeds"]:
        goals = sum(o == "goal" for o in s["outcomes"].values())
        lines.append(
            f"| {s['policy']} | {s['gamma']} | {goals}/{len(s['outcomes'])} | {s['mean_q']:.3f} "
            f"| {s['mean_return']:.3f} | {_ratio_text(s['ratio'])} | {s['gap']:+.3f} "
            f"| {_verdict(s)} "
            f"| {result['median_best_gap'][s['policy']]:.4f} |"
        )
    lines += [
        "",
        "where the values miss: the same figures over the episodes that reached the goal and "
        "over the rest",
        "| policy | episodes | mean Q | discounted return | ratio | gap | tracks? |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for s in result["seeds"]:
        for group, c in s["by_outcome"].items():
            lines.append(
                f"| {s['policy']} | {c['episodes']} {group} | {c['mean_q']:.3f} "
                f"| {c['mean_return']:.3f} | {_ratio_text(c['ratio'])} | {c['gap']:+.3f} "
                f"| {_verdict(c)} |"
            )
    if result["agreement"] is not None:
        lines.append(
            f"greedy-action agreement over {result['agreement_pairs']} seed pairs on "
            f"{result['states']} visited states: {result['agreement']:.3f} "
            f"(chance {result['chance']:.3f})"
        )
    return "\n".join(lines)


@tool_main
def main(argv: list[str] | None = None) -> int:
    ap = ToolParser(prog="python -m tools.experiments.value_check")
    ap.add_argument("directory", type=Path, help="a policy folder, or a folder of seed-<k>/")
    ap.add_argument("--json", action="store_true")
    ap.add_argument(
        "--episodes", action="store_true", help="also one row per greedy episode and seed"
    )
    ap.add_argument(
        "--epsilon",
        type=float,
        default=0.0,
        help="act epsilon-greedily (a diagnostic: do the values follow the exploring "
        "behaviour's returns rather than the greedy policy's?); default 0, greedy",
    )
    ap.add_argument(
        "--worlds",
        default=",".join(WORLDS),
        help="comma-separated worlds of the episodes (default: R1-R3 and three fresh "
        "layouts); e.g. TS1,TS2,TS3,TS4 to read the values on the training worlds, or "
        f"'{VALIDATION}' for each seed's own validation layouts (its config's eval_worlds)",
    )
    args = ap.parse_args(argv)
    worlds = tuple(w.strip() for w in args.worlds.split(",") if w.strip())
    if not worlds:
        print(f"value_check: error: --worlds names no world: {args.worlds!r}", file=sys.stderr)
        return 2
    if not 0.0 <= args.epsilon <= 1.0:
        print(
            f"value_check: error: --epsilon must be in [0, 1], got {args.epsilon}", file=sys.stderr
        )
        return 2
    try:
        for world in worlds if worlds != (VALIDATION,) else ():  # checked before any episode
            resolve_world(world, allow_eval_worlds=True, where="--worlds")
        result = check(args.directory, args.epsilon, worlds)
    except (D3DWAError, OSError) as err:
        fail("value_check", str(err))
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(describe(result))
        if args.episodes:
            print("\n" + describe_episodes(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
