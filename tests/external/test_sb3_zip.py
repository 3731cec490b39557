"""A Stable-Baselines3 DQN zip as a parameter chooser: read without unpickling, greedy as SB3's
own ``predict``, its declared terms checked against the zip, hostile or truncated files refused
in one line (docs/design/external-methods.md#external-methods)."""

from __future__ import annotations

import base64
import json
import pickle
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

sb3 = pytest.importorskip("stable_baselines3", reason="the sb3 extra is not installed")

from d3dwa_bullet.controllers import make_controller  # noqa: E402
from d3dwa_bullet.episode import EpisodeConfig, run_episode  # noqa: E402
from d3dwa_bullet.errors import ExternalMethodError  # noqa: E402
from d3dwa_bullet.external.resolve import resolve  # noqa: E402
from d3dwa_bullet.external.sb3_zip import SB3Chooser, read_dqn_zip  # noqa: E402
from d3dwa_bullet.params import TerminationParams  # noqa: E402
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY  # noqa: E402
from d3dwa_bullet.world.registry import load_world  # noqa: E402
from tests.external.test_external_episodes import same_episode  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "sb3_dqn"
ZIP = EXAMPLE / "sb3_dqn" / "dqn_d3dwa.zip"
SHORT = EpisodeConfig(termination=TerminationParams(time_limit=8.0))


class Shipped(SB3Chooser):
    model_file = ZIP
    actions = ACTIONS_FULL


class Trusted(Shipped):
    trust_pickle = True


class WrongSet(Shipped):
    actions = ACTIONS_WEIGHTS_ONLY


def test_the_zip_read_without_pickle_is_sb3s_greedy_policy():
    model = sb3.DQN.load(ZIP, device="cpu")  # our own file: trusted here
    ours = Shipped()
    obs = np.random.default_rng(0).uniform(-1, 1, (500, 12)).astype(np.float32)
    theirs = model.predict(obs, deterministic=True)[0]
    assert [ours.choose(o) for o in obs] == list(theirs)
    assert len(set(theirs)) > 1  # not a constant policy: the test could fail
    layers, n, dim = read_dqn_zip(ZIP)
    assert (n, dim, len(layers)) == (100, 12, 3)


def test_the_example_runs_its_declared_terms_the_same_either_way(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    name = "sb3_dqn.chooser:SB3DQN"
    method = resolve(name)
    assert (method.actions, method.hold, method.observation) == (ACTIONS_FULL, 1, "paper")
    world = load_world("R1")
    safe = run_episode(world, make_controller(name), config=SHORT)
    trusted = run_episode(world, make_controller(f"{__name__}:Trusted"), config=SHORT)
    same_episode(safe, trusted)
    for module in ("sb3_dqn.chooser", "sb3_dqn"):
        sys.modules.pop(module, None)


def test_a_declaration_that_does_not_fit_the_zip_is_refused():
    with pytest.raises(ExternalMethodError, match="maps 12 observations to 100 actions"):
        WrongSet()


def _rewrite(tmp_path: Path, change) -> Path:
    out = tmp_path / "hostile.zip"
    with zipfile.ZipFile(ZIP) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "data":
                data = json.dumps(change(json.loads(data))).encode()
            dst.writestr(item, data)
    return out


class _Marker:
    def __reduce__(self):
        return (Path.touch, (Path(MARKER),))


MARKER = ""


def test_a_pickled_policy_kwargs_is_never_unpickled(tmp_path):
    global MARKER
    MARKER = str(tmp_path / "ran")
    payload = base64.b64encode(pickle.dumps({"activation_fn": _Marker()})).decode()
    hostile = _rewrite(
        tmp_path, lambda d: d | {"policy_kwargs": {":type:": "dict", ":serialized:": payload}}
    )
    with pytest.raises(ExternalMethodError, match="policy_kwargs is pickled") as err:
        read_dqn_zip(hostile)
    assert "\n" not in str(err.value) and not Path(MARKER).exists()


@pytest.mark.parametrize(
    ("damage", "said"),
    [
        (lambda b: b[: len(b) // 2], "not a readable SB3 zip"),
        (lambda b: b"PK\x03\x04" + b"\0" * 100, "not a readable SB3 zip"),
    ],
)
def test_a_truncated_zip_is_refused(tmp_path, damage, said):
    cut = tmp_path / "cut.zip"
    cut.write_bytes(damage(ZIP.read_bytes()))
    with pytest.raises(ExternalMethodError, match=said):
        read_dqn_zip(cut)


def test_another_policy_class_is_refused(tmp_path):
    other = _rewrite(tmp_path, lambda d: d | {"policy_class": {"__init__": "CnnPolicy.__init__"}})
    with pytest.raises(ExternalMethodError, match="not SB3's DQN MlpPolicy"):
        read_dqn_zip(other)


@pytest.mark.slow
def test_the_example_trains_a_zip_that_loads(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    from sb3_dqn.train import run as train  # the example's own module, on its path here

    out = train(steps=300, seed=1, out=tmp_path / "small.zip")
    assert read_dqn_zip(out)[1:] == (100, 12)
