"""Building the controller of a method (docs/design/methods.md#methods): a fixed tuple, a reference
method's uniform chooser with its decision period, or a learned method's greedy policy loaded
from a checkpoint directory (``policies/<name>/`` by default, or ``--policy PATH``) or from an
exported ONNX file (``--onnx FILE``, docs/design/onnx.md#onnx-policies), or a method from outside
the package (``package.module:Name`` or an entry point, docs/design/external-methods.md#external-methods).

Above the learning layer: loading a policy imports it. The facts about methods (names, action
sets, families) are :mod:`d3dwa_bullet.method_specs`; the controller itself is
:class:`d3dwa_bullet.planning.controller.Controller`.
"""

from __future__ import annotations

from pathlib import Path

from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.external.guard import external_controller
from d3dwa_bullet.external.resolve import ExternalMethod, resolve
from d3dwa_bullet.method_names import is_model_file
from d3dwa_bullet.method_specs import (
    FIXED,
    LEARNED,
    ONNX_METHODS,
    REFERENCE,
    check_method,
    method_family,
    method_observation,
    needs_policy,
    reference_of,
)
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.controller import Controller
from d3dwa_bullet.resources import policies_dir
from d3dwa_bullet.seed_dirs import seed_dirs


def default_policy_path(name: str, root: str | Path | None = None) -> Path:
    """Where method ``name``'s policies are: ``root/<name>/`` under a policy root
    (``--policy-root DIR``: seed folders kept outside the package), else the shipped
    ``policies/<name>/``."""
    return (policies_dir() if root is None else Path(root)) / name


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
    if name in FIXED:
        return Controller(name, fixed=FIXED[name], source="fixed")
    if method_family(name) == "external":
        method = resolve(name)
        return _onnx_file(method) if is_model_file(name) else external_controller(method)
    ref = reference_of(name)
    if ref is not None:
        base, hold = ref
        source = "reference" + (f" (one draw every {hold} control steps)" if hold > 1 else "")
        return Controller(name, actions=REFERENCE[base], source=source, uniform=True, hold=hold)
    if onnx is not None:
        return _onnx_controller(name, policy_path, onnx)
    # start-up cost, and the robot extra: loading a checkpoint's weights.pt imports torch (seconds),
    # which fixed and reference methods, an ONNX policy (a robot without torch) and a checkpoint
    # carrying weights.npz (every shipped D3QN seed: docs/design/episode-cost.md) never need
    from d3dwa_bullet.learning.agents.checkpoint_files import META_FILE
    from d3dwa_bullet.learning.agents.numpy_policy import load_numpy_policy
    from d3dwa_bullet.learning.agents.policy_terms import checkpoint_terms

    path, source = one_policy(name, policy_path)
    kind = method_observation(name)
    fed = (kind, f"method {name!r}")
    loaded = load_numpy_policy(path, expected_actions=LEARNED[name], expected_observation=fed)
    if loaded is None:
        from d3dwa_bullet.learning.agents.policy import load_policy

        loaded = load_policy(path, expected_actions=LEARNED[name], expected_observation=fed)
    policy, actions, meta = loaded
    hold, trained_in, behind = checkpoint_terms(meta, str(path / META_FILE))
    return _learned(name, policy, actions, source, hold, trained_in, behind)


def refuse_policy(
    name: str, policy_path: str | Path | None, onnx: str | Path | None = None
) -> None:
    """ConfigError if a policy (--policy or --onnx) is given to a method that needs none: it
    would be ignored, and the run would not be what was asked for."""
    if needs_policy(name):
        return
    family = method_family(name)
    family = f"{'an' if family[0] in 'aeiou' else 'a'} {family}"
    if policy_path is not None:
        raise ConfigError(
            f"--policy {policy_path}: method {name!r} is {family} method and needs no "
            f"policy; --policy goes with a learned method ({', '.join(LEARNED)})"
        )
    if onnx is not None:
        raise ConfigError(
            f"{onnx}: method {name!r} does not run a network ({family} method needs no "
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
    return _learned(
        name, policy, actions, source, meta["decision_steps"], meta["recovery"], meta["scan_filter"]
    )


def _onnx_file(method: ExternalMethod) -> Controller:
    """The controller of an ONNX file named as a method: its policy run greedily over the
    action set, decision period and observation its metadata declare
    (docs/design/external-methods.md#external-methods); the recovery layer and scan filter it trained with are
    noted as for a policy."""
    # the optional `robot` extra (onnxruntime), imported only when a file is run
    from d3dwa_bullet.learning.agents.onnx_policy import load_onnx_policy

    expected = (method.observation, f"method {method.name!r}")
    policy, actions, meta = load_onnx_policy(
        method.name, expected_actions=method.actions, expected_observation=expected
    )
    controller = _learned(
        method.name, policy, actions, f"{method.origin} (ONNX, exported for {meta['method']})",
        meta["decision_steps"], meta["recovery"], meta["scan_filter"],
    )  # fmt: skip
    controller.observation, controller.origin = method.observation, method.origin
    return controller


def _learned(
    name: str,
    policy: object,
    actions: ActionSet,
    source: str,
    hold: int,
    trained_in: str,
    behind: str = "none",
) -> Controller:
    """The controller of a learned method's loaded policy (torch or ONNX, the same way): it
    holds each action for the policy's decision period, and its source notes that period
    and the recovery layer the policy trained inside, which a run must ask for itself. It
    carries the scan filter the policy trained behind (``behind``), which whatever drives it
    checks against its own (``check_driven_filter``)."""
    if hold > 1:
        source += f" (one decision every {hold} control steps)"
    if trained_in != "none":
        source += f" (trained inside the recovery layer {trained_in!r}: run with --recovery so)"
    if behind != "none":
        source += f" (trained behind the scan filter {behind!r})"
    kind = method_observation(name)
    return Controller(
        name, policy=policy, actions=actions, source=source, observation=kind, hold=hold,
        scan_filter=behind,
    )  # fmt: skip


def one_policy(name: str, policy_path: str | Path | None = None) -> tuple[Path, str]:
    """(folder, description) of the one policy a single episode of a learned method drives:
    policy_path (default: the shipped ``policies/<name>/``), or, for a folder of training
    seeds, its lowest seed, never one chosen by its results (``d3dwa eval`` and ``d3dwa
    sweep`` drive every seed). CheckpointError if there is none."""
    path = Path(policy_path) if policy_path is not None else default_policy_path(name)
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
