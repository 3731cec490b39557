"""A Stable-Baselines3 DQN saved as a ``.zip``, run greedily as a parameter chooser, without
unpickling anything it holds (docs/design/external-methods.md#external-methods).

An SB3 zip holds ``data`` (JSON, where every object that is not plain JSON is a base64
cloudpickle) and ``policy.pth`` (a torch state dict). Loading it with ``DQN.load`` unpickles
the former: code from whoever made the file would run. Here only plain JSON is read (the
policy class's name, the action space's ``n``, the observation space's shape, a plain
``net_arch``), the state dict with ``torch.load(weights_only=True)``, and the Q-network's
forward pass is the MLP SB3's ``MlpPolicy`` builds (linear layers, ReLU between), argmax as its
``predict(deterministic=True)``. A file that needs more (another activation, a custom
feature extractor: pickled ``policy_kwargs``) is refused unless the chooser's class says
``trust_pickle = True``, which runs ``DQN.load`` itself.

An SB3 zip records no env id and no wrappers, so the terms it was trained under (action set,
decision period, observation) are declared by the class that names it
(:class:`SB3Chooser`) and checked against the sizes the zip does record.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from d3dwa_bullet.errors import ExternalMethodError
from d3dwa_bullet.limits import MAX_DOCUMENT_BYTES, MAX_POLICY_BYTES
from d3dwa_bullet.loading import parse_json
from d3dwa_bullet.planning.actions import ActionSet
from d3dwa_bullet.planning.observation_kinds import observation_layout

_PREFIX = "q_net.q_net."
_PLAIN_KWARGS = {"net_arch"}


def _member(archive: zipfile.ZipFile, name: str, limit: float, where: str) -> bytes:
    try:
        info = archive.getinfo(name)
    except KeyError:
        raise ExternalMethodError(f"{where}: no {name!r} in the zip (not an SB3 model)") from None
    if info.file_size > limit:
        raise ExternalMethodError(f"{where}: {name!r} is {info.file_size} bytes, over {limit}")
    return archive.read(info)


def _plain(value: Any, what: str, where: str) -> Any:
    if isinstance(value, dict) and ":serialized:" in value:
        raise ExternalMethodError(
            f"{where}: its {what} is pickled ({value.get(':type:', '?')}); refusing to unpickle a "
            "file (a class with trust_pickle = True loads it with SB3 itself)"
        )
    return value


def read_dqn_zip(path: str | Path) -> tuple[list[tuple[Any, Any]], int, int]:
    """(layers [(weight, bias) torch tensors], actions n, observation dim) of an SB3 DQN
    zip, read without unpickling; ExternalMethodError (one line, the file) otherwise."""
    # start-up cost and an optional extra: torch, needed only when an SB3 file is run
    import torch

    where = str(path)
    file = Path(path)
    if not file.is_file():
        raise ExternalMethodError(f"{where}: no such file")
    MAX_POLICY_BYTES.check(where, file.stat().st_size, "bytes", ExternalMethodError)
    try:
        with zipfile.ZipFile(file) as archive:
            text = _member(archive, "data", MAX_DOCUMENT_BYTES.value, where)
            weights = _member(archive, "policy.pth", MAX_POLICY_BYTES.value, where)
    except (zipfile.BadZipFile, UnicodeDecodeError, OSError) as err:
        raise ExternalMethodError(f"{where}: not a readable SB3 zip ({err})") from err
    data = parse_json(text, ExternalMethodError, f"{where}: its data")
    if not isinstance(data, dict):
        raise ExternalMethodError(f"{where}: its data is not a JSON object")
    policy = data.get("policy_class", {})
    init = str(policy.get("__init__", "")) if isinstance(policy, dict) else ""
    if "DQNPolicy.__init__" not in init:  # MlpPolicy is DQNPolicy; Cnn/MultiInput are not
        raise ExternalMethodError(f"{where}: its policy is not SB3's DQN MlpPolicy ({init:.60})")
    kwargs = _plain(data.get("policy_kwargs", {}), "policy_kwargs", where)
    if not isinstance(kwargs, dict) or set(kwargs) - _PLAIN_KWARGS:
        raise ExternalMethodError(
            f"{where}: policy_kwargs {sorted(kwargs) if isinstance(kwargs, dict) else kwargs!r} "
            "need SB3 to rebuild; only net_arch is read without it"
        )
    try:
        n = int(data["action_space"]["n"])
        dim = int(np.prod(data["observation_space"]["_shape"]))
        state = torch.load(io.BytesIO(weights), map_location="cpu", weights_only=True)
    except (KeyError, TypeError, ValueError, RuntimeError, EOFError) as err:
        raise ExternalMethodError(f"{where}: cannot read its spaces or weights ({err})") from err
    layers, k = [], 0
    while f"{_PREFIX}{k}.weight" in state:
        layers.append((state[f"{_PREFIX}{k}.weight"].float(), state[f"{_PREFIX}{k}.bias"].float()))
        k += 2  # a ReLU between each two linear layers
    shapes = [tuple(w.shape) for w, _ in layers]
    chained = all(a[0] == b[1] for a, b in zip(shapes, shapes[1:], strict=False))
    if not layers or shapes[0][1] != dim or shapes[-1][0] != n or not chained:
        raise ExternalMethodError(
            f"{where}: its q_net layers {shapes} do not map {dim} observations to {n} Q-values"
        )
    return layers, n, dim


class SB3Chooser:
    """A parameter chooser that runs an SB3 DQN zip greedily. Subclass it and declare
    ``model_file`` and the terms it was trained under: ``actions``, ``hold`` (the env's
    ``decision_steps``) and ``observation``; the zip's sizes are checked against them."""

    interface_version = 1
    model_file: ClassVar[str | Path]
    actions: ClassVar[ActionSet]
    hold: ClassVar[int] = 1
    observation: ClassVar[str] = "paper"
    trust_pickle: ClassVar[bool] = False
    """True: load the zip with ``DQN.load`` (unpickling it). Only for a file you made."""

    def __init__(self) -> None:
        where = str(self.model_file)
        if self.trust_pickle:
            # an optional extra, and code from the file runs: only when the class says so
            from stable_baselines3 import DQN

            model = DQN.load(self.model_file, device="cpu")
            self._greedy = lambda obs: int(model.predict(obs, deterministic=True)[0])
            n = int(model.action_space.n)  # type: ignore[attr-defined]
            dim = int(np.prod(model.observation_space.shape or ()))
        else:
            layers, n, dim = read_dqn_zip(self.model_file)
            self._greedy = _mlp_greedy(layers)
        if n != len(self.actions) or dim != len(observation_layout(self.observation)):
            raise ExternalMethodError(
                f"{where}: the zip maps {dim} observations to {n} actions; its class declares "
                f"the {self.observation!r} observation ({len(observation_layout(self.observation))}) "
                f"and {len(self.actions)} actions"
            )

    def reset(self, episode_seed: int) -> None:
        """Nothing to reset: a greedy policy keeps no state."""

    def choose(self, obs: np.ndarray) -> int:
        return self._greedy(obs)


def _mlp_greedy(layers: list[tuple[Any, Any]]):
    """argmax of SB3's MlpPolicy Q-network forward pass: float32, ReLU between layers."""
    # start-up cost: torch only when an SB3 file runs; torch's own float32 ops, so the argmax
    # is SB3's own
    import torch
    from torch.nn import functional

    def greedy(obs: np.ndarray) -> int:
        with torch.no_grad():
            x = torch.as_tensor(np.asarray(obs)).float().reshape(1, -1)
            for i, (weight, bias) in enumerate(layers):
                x = functional.linear(x, weight, bias)
                if i < len(layers) - 1:
                    x = functional.relu(x)
            return int(x.argmax(dim=1)[0])

    return greedy
