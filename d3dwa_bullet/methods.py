"""The methods every command and table knows, by their stable names (docs/design.md#methods).

A *controller* maps an observation to the DWA parameters of one control step; the planner
then does the rest. Fixed baselines return constants; the ``random`` reference method draws
an action uniformly every step from a generator the episode seed seeds
(:meth:`Controller.reset`); learned methods run a greedy policy loaded from a checkpoint
directory (``policies/<name>/`` by default, or ``--policy PATH``), or from an exported ONNX
file (``--onnx FILE``, docs/design.md#onnx-policies).

Three families: ``fixed`` and ``reference`` methods need no policy (one run each, no
training seeds); ``learned`` ones load one per training seed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from d3dwa_bullet.errors import CheckpointError, ConfigError, UnknownNameError
from d3dwa_bullet.planning.actions import (
    ACTIONS_FULL,
    ACTIONS_WEIGHTS_ONLY,
    ActionSet,
    PlannerAction,
)
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.seed_dirs import seed_dirs

FIXED: dict[str, PlannerAction] = {
    "dwa1": PlannerAction(1.0, 1.0, 2.0, 4.0),
    "dwa2": PlannerAction(1.0, 2.0, 1.0, 4.0),
    "dwa3": PlannerAction(2.0, 1.0, 1.0, 4.0),
}
#: Reference methods and the action set each draws from uniformly, every control step: a floor
#: a learned method must clear (docs/design.md#methods). They need no policy. ``random`` is
#: the floor of the 100-action methods, ``random-weights`` of the 25-action ones (SPEC 6:
#: uniform over the method's action set).
REFERENCE: dict[str, ActionSet] = {"random": ACTIONS_FULL, "random-weights": ACTIONS_WEIGHTS_ONLY}
#: The tag that keeps a reference method's draws a stream of their own: its generator is
#: seeded by SeedSequence([episode seed, RANDOM_STREAM]), which no other draw of an episode
#: uses (noise and the env's tasks spawn from SeedSequence(episode seed)). ASCII "rand".
RANDOM_STREAM = 0x72616E64
#: Learned methods and the action set their policy must have.
LEARNED: dict[str, ActionSet] = {
    "dqdwa": ACTIONS_WEIGHTS_ONLY,
    "d3dwa-weights": ACTIONS_WEIGHTS_ONLY,
    "d3dwa": ACTIONS_FULL,
    "d3dwa-dr": ACTIONS_FULL,
    "d3dwa-pa": ACTIONS_FULL,
    "d3dwa-pa-dr": ACTIONS_FULL,
}
#: The observation kind each learned method's policy reads (docs/design.md#progress-observation);
#: the rest read the paper's 12-d state. ``d3dwa-pa`` and ``d3dwa-pa-dr`` are beyond the paper.
OBSERVATIONS: dict[str, str] = {"d3dwa-pa": "progress", "d3dwa-pa-dr": "progress"}
#: Learned methods whose policy is a network, so exports to ONNX (dqdwa's is a Q-table).
ONNX_METHODS = tuple(m for m in LEARNED if m != "dqdwa")
METHODS = tuple(FIXED) + tuple(REFERENCE) + tuple(LEARNED)
#: Methods that need no policy: one run each, no training seeds, no --policy / --onnx.
NO_POLICY = frozenset(FIXED) | frozenset(REFERENCE)
#: Methods beyond the paper (SPEC sections 4 and 6): they sit beside the paper's methods and
#: never change the paper's track, so the main job and its tables leave them out unless named.
BEYOND_PAPER = frozenset({"d3dwa-pa", "d3dwa-pa-dr"})
#: Learned methods that ship no policy, and why: a command that would load the shipped policy
#: says this in its one line instead of "no policy". The seeds of the diverging learner were
#: retired (docs/results.md#retired-seeds); a method leaves this map when the seeds of its
#: committed config ship.
RETIRED = "its seeds of the diverging learner were retired (docs/results.md#retired-seeds)"
UNSHIPPED: dict[str, str] = {
    "d3dwa-pa": RETIRED,
    "d3dwa-pa-dr": RETIRED,
}
LABELS = {
    "dwa1": "DWA I (1,1,2)",
    "dwa2": "DWA II (1,2,1)",
    "dwa3": "DWA III (2,1,1)",
    "random": f"Random (uniform over {REFERENCE['random'].size} actions)",
    "random-weights": f"Random (uniform over {REFERENCE['random-weights'].size} actions)",
    "dqdwa": "DQDWA",
    "d3dwa-weights": "D3DWA (w/o horizon)",
    "d3dwa": "D3DWA",
    "d3dwa-dr": "D3DWA (randomised)",
    "d3dwa-pa": "D3DWA-PA (beyond paper)",
    "d3dwa-pa-dr": "D3DWA-PA (randomised)",
}


def method_family(name: str) -> str:
    """``fixed``, ``reference`` or ``learned`` (UnknownNameError for an unknown method)."""
    check_method(name)
    return "fixed" if name in FIXED else "reference" if name in REFERENCE else "learned"


@dataclass
class Controller:
    """Chooses (action index, PlannerAction) from an observation; index -1 for fixed methods.
    ``observation`` is the kind it reads, which the episode loop and the replay build.

    Whatever drives a controller through an episode calls :meth:`reset` with the episode
    seed before the first step (``run_episode`` does; a bag replay with its ``seed``)."""

    name: str
    fixed: PlannerAction | None = None
    policy: object | None = None
    actions: ActionSet | None = None
    source: str = ""
    observation: str = "paper"
    uniform: bool = False
    """Draws its index uniformly from ``actions`` every step (a reference method), ignoring
    the observation."""
    hold: int = 1
    """Control steps each chosen action is kept for: a policy trained with ``decision_steps``
    k > 1 (beyond the paper, docs/design.md#decision-period) chooses every k steps."""
    _rng: np.random.Generator | None = field(default=None, init=False, repr=False)
    _held: tuple[int, int] | None = field(default=None, init=False, repr=False)

    def reset(self, episode_seed: int) -> None:
        """Start an episode. A uniform controller seeds its own generator from the episode
        seed (``RANDOM_STREAM``): the same seed gives the same actions, and no other stream of
        the episode is drawn from. The others keep no state across steps: nothing to do.
        ConfigError for a seed numpy cannot take (negative). A held action ends here."""
        self._held = None
        if not self.uniform:
            return
        if int(episode_seed) < 0:
            raise ConfigError(
                f"--seed {episode_seed}: method {self.name!r} draws its actions from the "
                "episode seed, which must be >= 0"
            )
        sequence = np.random.SeedSequence([int(episode_seed), RANDOM_STREAM])
        self._rng = np.random.default_rng(sequence)

    def __call__(self, obs: np.ndarray) -> tuple[int, PlannerAction]:
        if self.fixed is not None:
            return -1, self.fixed
        if self._held is not None and self._held[1] > 0:
            index, left = self._held
            self._held = (index, left - 1)
            return index, self.actions.decode(index)  # type: ignore[union-attr]
        if self.uniform:
            if self._rng is None:
                raise RuntimeError(
                    f"controller {self.name!r} draws from the episode seed: call "
                    "reset(episode_seed) before the episode's first step"
                )
            index = int(self._rng.integers(len(self.actions)))  # type: ignore[arg-type]
        else:
            index = int(self.policy(obs))  # type: ignore[misc]
        if self.hold > 1:
            self._held = (index, self.hold - 1)
        return index, self.actions.decode(index)  # type: ignore[union-attr]


def check_method(name: str) -> str:
    if name not in METHODS:
        raise UnknownNameError(f"unknown method {name!r}: choose one of {', '.join(METHODS)}")
    return name


def method_observation(name: str) -> str:
    """The observation kind a method's controller reads ("paper" or "progress")."""
    return OBSERVATIONS.get(check_method(name), "paper")


def default_policy_path(name: str) -> Path:
    return policies_dir() / name


def make_controller(
    name: str, policy_path: str | Path | None = None, onnx: str | Path | None = None
) -> Controller:
    """The controller of a method; learned ones load their policy (CheckpointError if absent).

    policy_path: a checkpoint directory (default: the shipped ``policies/<name>/``); onnx: an
    ONNX file exported by ``d3dwa export --onnx``, run by onnxruntime without torch (the
    file's observation kind and action set must be the method's). Not both, and neither for
    a method that needs no policy (ConfigError naming the value). Either way the controller
    holds each action for the decision period the policy recorded (``policy_terms``).
    """
    check_method(name)
    refuse_policy(name, policy_path, onnx)
    if name in NO_POLICY:
        if name in FIXED:
            return Controller(name, fixed=FIXED[name], source="fixed")
        return Controller(name, actions=REFERENCE[name], source="reference", uniform=True)
    if onnx is not None:
        return _onnx_controller(name, policy_path, onnx)
    # start-up cost, and layering: loading a policy imports torch and the learning layer,
    # which fixed methods (and every pure caller of this registry) never need
    from d3dwa_bullet.learning.agents.checkpoint import META_FILE
    from d3dwa_bullet.learning.agents.policy import load_policy
    from d3dwa_bullet.learning.agents.policy_terms import checkpoint_terms

    path, source = one_policy(name, policy_path)
    kind = method_observation(name)
    policy, actions, meta = load_policy(
        path, expected_actions=LEARNED[name], expected_observation=(kind, f"method {name!r}")
    )
    hold, trained_in = checkpoint_terms(meta, str(path / META_FILE))
    return _learned(name, policy, actions, source, hold, trained_in)


def refuse_policy(
    name: str, policy_path: str | Path | None, onnx: str | Path | None = None
) -> None:
    """ConfigError if a policy (--policy or --onnx) is given to a method that needs none: it
    would be ignored, and the run would not be what was asked for."""
    if name not in NO_POLICY:
        return
    family = method_family(name)
    if policy_path is not None:
        raise ConfigError(
            f"--policy {policy_path}: method {name!r} is a {family} method and needs no "
            f"policy; --policy goes with a learned method ({', '.join(LEARNED)})"
        )
    if onnx is not None:
        raise ConfigError(
            f"{onnx}: method {name!r} does not run a network (a {family} method needs no "
            f"policy); an ONNX policy drives one of {', '.join(ONNX_METHODS)}"
        )


def _onnx_controller(name: str, policy_path: str | Path | None, onnx: str | Path) -> Controller:
    if policy_path is not None:
        raise ConfigError(
            f"a policy directory ({policy_path}) and an ONNX file ({onnx}) both name the "
            f"policy of method {name!r}: give one"
        )
    if name not in ONNX_METHODS:
        raise ConfigError(
            f"{onnx}: method {name!r} does not run a network; an ONNX policy drives one of "
            f"{', '.join(ONNX_METHODS)}"
        )
    # the optional `robot` extra (onnxruntime), imported only when a file is run; this
    # path never imports torch, so a robot without torch can drive
    from d3dwa_bullet.learning.agents.onnx_policy import load_onnx_policy

    kind = method_observation(name)
    policy, actions, meta = load_onnx_policy(
        onnx, expected_actions=LEARNED[name], expected_observation=(kind, f"method {name!r}")
    )
    source = f"{onnx} (ONNX, exported for {meta['method']})"
    return _learned(name, policy, actions, source, meta["decision_steps"], meta["recovery"])


def _learned(
    name: str, policy: object, actions: ActionSet, source: str, hold: int, trained_in: str
) -> Controller:
    """The controller of a learned method's loaded policy (torch or ONNX, the same way): it
    holds each action for the policy's decision period, and its source notes that period
    and the recovery layer the policy trained inside, which a run must ask for itself."""
    if hold > 1:
        source += f" (one decision every {hold} control steps)"
    if trained_in != "none":
        source += f" (trained inside the recovery layer {trained_in!r}: run with --recovery so)"
    kind = method_observation(name)
    return Controller(
        name, policy=policy, actions=actions, source=source, observation=kind, hold=hold
    )


def one_policy(name: str, policy_path: str | Path | None = None) -> tuple[Path, str]:
    """(folder, description) of the one policy a single episode of a learned method drives:
    policy_path (default: the shipped ``policies/<name>/``), or, for a folder of training
    seeds, its lowest seed, never one chosen by its results (``d3dwa eval`` and ``d3dwa
    sweep`` drive every seed). CheckpointError if there is none."""
    path = Path(policy_path) if policy_path is not None else default_policy_path(name)
    if not path.exists() and policy_path is None and name in UNSHIPPED:
        raise CheckpointError(
            f"{path}: method {name!r} ships no policy: {UNSHIPPED[name]}; train its seeds with "
            f"`d3dwa train --method {name} --seeds 0-4 --out runs/{name} --export "
            f"my_policies/{name}` and pass --policy my_policies/{name}"
        )
    if not path.exists():
        raise CheckpointError(
            f"{path}: no policy for method {name!r}; train one with `d3dwa train --method {name}` "
            "or pass --policy PATH"
        )
    seeds = seed_dirs(path)
    if seeds and not (path / "meta.json").exists():
        first = next(iter(seeds))
        return seeds[first], f"{seeds[first]} (training seed {first} of {len(seeds)})"
    return path, str(path)
