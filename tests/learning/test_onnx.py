"""ONNX export and its onnxruntime policy: the Q-values and greedy actions of torch and of the
numpy policy on every shipped network method (and a fresh 17-d progress network), the
recorded golden actions, one-line refusals of what does not fit, nothing written by a
refused export, and a runner that neither imports nor needs torch."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import onnx
import pytest

import d3dwa_bullet.learning.agents as agents
from d3dwa_bullet.controllers import default_policy_path, make_controller
from d3dwa_bullet.errors import CheckpointError, ConfigError
from d3dwa_bullet.learning.agents import onnx_export, onnx_guard, onnx_policy
from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint, read_meta, save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent
from d3dwa_bullet.learning.agents.onnx_export import export_onnx, q_values, sample_observations
from d3dwa_bullet.learning.agents.onnx_policy import METADATA_KEYS, load_onnx_policy, onnx_metadata
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.limits import Limit
from d3dwa_bullet.method_specs import LEARNED, ONNX_METHODS, method_observation
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from d3dwa_bullet.planning.observation_kinds import observation_layout
from d3dwa_bullet.seed_dirs import seed_dirs
from tests.learning.test_shipped_policies import (
    GOLDEN_ACTIONS,
    OBSERVATIONS,
    decide,
    observations_for,
)

SHIPPED = {m: seed_dirs(default_policy_path(m)) for m in ONNX_METHODS}
SHIPPED_SEEDS = [(m, k) for m, seeds in SHIPPED.items() for k in seeds]
N_RANDOM = 10_000
REL_Q = 1e-6
"""|Q_onnx - Q_torch| / max(1, max |Q|) allowed here (about 8 float32 roundings; the export's
own check allows onnx_export.Q_TOLERANCE): an absolute 1e-5 is below one float32 step at the
|Q| of 130 some shipped seeds reach."""


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, int], Path]:
    """Every shipped seed of every network method, exported once."""
    out = tmp_path_factory.mktemp("onnx")
    return {
        (m, k): export_onnx(SHIPPED[m][k], out / m / f"seed-{k}.onnx").file
        for m, k in SHIPPED_SEEDS
    }


def one_line(err: pytest.ExceptionInfo, *names: object) -> str:
    """The error's message, checked to be one line naming each of names."""
    message = str(err.value)
    assert "\n" not in message, message
    for name in names:
        assert str(name) in message, (name, message)
    return message


def fresh_checkpoint(directory: Path, kind: str, hidden: tuple[int, ...], method: str) -> Path:
    agent = D3QNAgent(ACTIONS_FULL, D3QNConfig(hidden=hidden, seed=5), observation_layout(kind))
    return save_checkpoint(directory, agent, method=method)


def test_shipped_network_methods_are_there_to_test() -> None:
    # every network method with a policies/ folder is tested below (a method whose seeds are
    # still training has none yet), and the paper's is one of them
    shipping = {m for m in ONNX_METHODS if default_policy_path(m).exists()}
    assert {m for m, _ in SHIPPED_SEEDS} == shipping and "d3dwa" in shipping


@pytest.mark.parametrize("method", sorted({m for m, _ in SHIPPED_SEEDS}))
def test_seed0_matches_torch_and_numpy_on_random_observations(exported, method: str) -> None:
    path = SHIPPED[method][0]
    kind = (method_observation(method), method)
    agent, _ = load_checkpoint(
        path, expected_actions=LEARNED[method], expected_layout=observation_layout(kind[0])
    )
    assert isinstance(agent, D3QNAgent)
    numpy_policy, _, _ = load_policy(
        path, expected_actions=LEARNED[method], expected_observation=kind
    )
    policy, actions, meta = load_onnx_policy(
        exported[(method, 0)], expected_actions=LEARNED[method], expected_observation=kind
    )
    assert actions == LEARNED[method] and meta["method"] == method
    obs = sample_observations(agent.obs_layout, N_RANDOM, seed=2026)
    q_torch, q_onnx = q_values(agent.online, obs), policy.q_values(obs)
    assert q_onnx.shape == (N_RANDOM, actions.size) and q_onnx.dtype == np.float32
    assert np.abs(q_onnx - q_torch).max() <= REL_Q * max(1.0, np.abs(q_torch).max())
    onnx_actions = np.array([policy(o) for o in obs])
    assert len(np.unique(onnx_actions)) > 1  # a policy that varies, so agreement means something
    np.testing.assert_array_equal(onnx_actions, q_onnx.argmax(axis=1))
    np.testing.assert_array_equal(onnx_actions, [agent.act(o, greedy=True) for o in obs])
    np.testing.assert_array_equal(onnx_actions, [numpy_policy(o) for o in obs])


@pytest.mark.parametrize(("method", "seed"), SHIPPED_SEEDS)
def test_shipped_seed_chooses_the_golden_actions(exported, method: str, seed: int) -> None:
    policy, _, _ = load_onnx_policy(
        exported[(method, seed)],
        expected_actions=LEARNED[method],
        expected_observation=(method_observation(method), method),
    )
    assert [policy(o) for o in observations_for(method)] == GOLDEN_ACTIONS[method][seed]
    controller = make_controller(method, onnx=exported[(method, seed)])
    assert [decide(controller, o) for o in observations_for(method)] == GOLDEN_ACTIONS[method][seed]


def test_metadata_describes_the_source_checkpoint(exported) -> None:
    file = exported[("d3dwa", 0)]
    props = {p.key: p.value for p in onnx.load(file).metadata_props}
    meta = read_meta(SHIPPED["d3dwa"][0])
    source = json.loads(props[METADATA_KEYS["source"]])
    assert source["weights_sha256"] == meta["files"]["weights.pt"]["sha256"]
    assert source["training_steps"] == meta["training_steps"]
    assert source["hidden"] == meta["config"]["hidden"]
    assert json.loads(props[METADATA_KEYS["actions"]]) == ACTIONS_FULL.to_dict()
    assert props[METADATA_KEYS["observation_kind"]] == "paper"
    assert props[METADATA_KEYS["obs_dim"]] == "12"
    assert source["checkpoint"] == "policies/d3dwa/seed-0"  # not this machine's install path
    described = onnx_metadata(file)
    assert described["method"] == "d3dwa" and described["source"] == source
    assert described["actions"] == ACTIONS_FULL and described["observation"]["kind"] == "paper"


def test_export_is_deterministic(exported, tmp_path: Path) -> None:
    again = export_onnx(SHIPPED["d3dwa"][0], tmp_path / "again.onnx").file
    assert again.read_bytes() == exported[("d3dwa", 0)].read_bytes()


@pytest.mark.parametrize("hidden", [(32,), (64, 32, 16)])
def test_progress_network_round_trips(tmp_path: Path, hidden: tuple[int, ...]) -> None:
    ckpt = fresh_checkpoint(tmp_path / "pa", "progress", hidden, "d3dwa")
    result = export_onnx(
        ckpt,
        tmp_path / "pa.onnx",
        expected_actions=ACTIONS_FULL,
        expected_observation=("progress", "a progress reader"),
    )
    assert (result.method, result.observation, result.n_actions) == ("d3dwa", "progress", 100)
    agent, _ = load_checkpoint(ckpt, expected_layout=observation_layout("progress"))
    assert isinstance(agent, D3QNAgent)
    policy, _, meta = load_onnx_policy(result.file, expected_observation=("progress", "test"))
    assert meta["observation"]["dim"] == 17 and meta["source"]["checkpoint"] == str(ckpt)
    obs = sample_observations(agent.obs_layout, 2_000, seed=3)
    q_torch = q_values(agent.online, obs)
    assert np.abs(policy.q_values(obs) - q_torch).max() <= REL_Q * max(1.0, np.abs(q_torch).max())
    np.testing.assert_array_equal([policy(o) for o in obs], q_torch.argmax(axis=1))


def test_a_wrong_observation_kind_or_action_set_is_refused(exported, tmp_path: Path) -> None:
    paper = exported[("d3dwa", 0)]
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(paper, expected_observation=("progress", "a progress reader"))
    one_line(err, paper, "'paper' observation (12 entries)", "'progress' observation (17")
    with pytest.raises(CheckpointError) as err:
        make_controller("d3dwa-weights", onnx=paper)
    one_line(err, paper, "'size': 100", "'size': 25", "method 'd3dwa-weights'")
    progress = export_onnx(
        fresh_checkpoint(tmp_path / "pa", "progress", (16,), "d3dwa"), tmp_path / "pa.onnx"
    ).file
    with pytest.raises(CheckpointError) as err:
        make_controller("d3dwa", onnx=progress)
    one_line(err, progress, "'progress' observation", "method 'd3dwa' feeds the 'paper'")


def test_exporting_a_paper_checkpoint_for_a_progress_reader_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError) as err:
        export_onnx(
            SHIPPED["d3dwa"][0],
            tmp_path / "x.onnx",
            expected_observation=("progress", "a progress reader"),
        )
    one_line(err, "a progress reader", "'paper'")
    assert not list(tmp_path.iterdir())


def test_the_tabular_agent_is_refused_and_nothing_written(tmp_path: Path) -> None:
    dqdwa = save_checkpoint(tmp_path / "tabular", DQDWAAgent(), method="dqdwa")
    with pytest.raises(CheckpointError) as err:
        export_onnx(dqdwa, tmp_path / "dqdwa.onnx")
    one_line(err, dqdwa, "not a network")
    assert [p.name for p in tmp_path.iterdir()] == ["tabular"]  # no .onnx beside it


def test_a_failed_check_writes_nothing_and_keeps_the_old_file(tmp_path, monkeypatch) -> None:
    out = tmp_path / "policy.onnx"
    out.write_bytes(b"the previous export")
    torch_q = onnx_export.q_values
    monkeypatch.setattr(onnx_export, "q_values", lambda net, obs: torch_q(net, obs) + 1e-3)
    with pytest.raises(CheckpointError) as err:
        export_onnx(SHIPPED["d3dwa"][0], out)
    one_line(err, out, "not written")
    assert out.read_bytes() == b"the previous export"
    assert [p.name for p in tmp_path.iterdir()] == ["policy.onnx"]  # no temporary left


def _model_with_props(file: Path, **changes: str) -> bytes:
    model = onnx.load(file)
    props = {p.key: p.value for p in model.metadata_props} | changes
    del model.metadata_props[:]
    onnx.helper.set_model_props(model, props)
    return model.SerializeToString()


def _foreign_model() -> bytes:
    x = onnx.helper.make_tensor_value_info("x", onnx.TensorProto.FLOAT, [1, 12])
    y = onnx.helper.make_tensor_value_info("y", onnx.TensorProto.FLOAT, [1, 12])
    graph = onnx.helper.make_graph([onnx.helper.make_node("Identity", ["x"], ["y"])], "g", [x], [y])
    opset = [onnx.helper.make_opsetid("", 17)]
    model = onnx.helper.make_model(
        graph, opset_imports=opset, ir_version=onnx.helper.find_min_ir_version_for(opset)
    )
    return model.SerializeToString()


@pytest.mark.parametrize(
    ("content", "says"),
    [
        (lambda src: b"\x00not an onnx model at all", "not an ONNX model onnxruntime can load"),
        (lambda src: _foreign_model(), "not a d3dwa policy"),
        (
            lambda src: _model_with_props(src, **{METADATA_KEYS["format_version"]: "99"}),
            "'99', this code reads versions 1, 2",
        ),
        (
            lambda src: _model_with_props(
                src,
                **{
                    METADATA_KEYS["observation_kind"]: "progress",
                    METADATA_KEYS["observation_layout"]: json.dumps(
                        list(observation_layout("progress"))
                    ),
                    METADATA_KEYS["obs_dim"]: "17",
                },
            ),
            "do not fit its metadata",
        ),
        (
            lambda src: _model_with_props(src, **{METADATA_KEYS["actions"]: "{"}),
            "not valid JSON",
        ),
    ],
    ids=["garbage", "foreign", "version", "signature", "actions-json"],
)
def test_a_file_that_is_not_our_policy_is_refused(exported, tmp_path, content, says) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(content(exported[("d3dwa", 0)]))
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(bad, expected_observation=("progress", "test"))
    one_line(err, bad, says)
    with pytest.raises(CheckpointError) as err:
        onnx_metadata(bad)
    one_line(err, bad, says)


def test_missing_files_directories_and_huge_files_are_refused(exported, tmp_path, monkeypatch):
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(tmp_path / "nope.onnx")
    one_line(err, tmp_path / "nope.onnx", "missing")
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(tmp_path)
    one_line(err, tmp_path, "a directory")
    monkeypatch.setattr(onnx_guard, "MAX_POLICY_BYTES", Limit(1_000, "a test's limit"))
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(exported[("d3dwa", 0)])
    one_line(err, exported[("d3dwa", 0)], "over the limit of 1000 bytes")
    with pytest.raises(CheckpointError) as err:
        export_onnx(SHIPPED["d3dwa"][0], tmp_path)
    one_line(err, tmp_path, "is a directory")


def test_missing_extras_are_one_line(exported, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # import onnxruntime -> ImportError
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(exported[("d3dwa", 0)])
    one_line(err, exported[("d3dwa", 0)], "onnxruntime is not installed", "d3dwa-bullet[robot]")
    monkeypatch.setitem(sys.modules, "onnx", None)
    with pytest.raises(CheckpointError) as err:
        export_onnx(SHIPPED["d3dwa"][0], tmp_path / "x.onnx")
    one_line(err, SHIPPED["d3dwa"][0], "onnx package is not installed")
    assert not list(tmp_path.iterdir())


def test_make_controller_refuses_onnx_beside_a_policy_or_for_a_non_network(exported) -> None:
    file = exported[("d3dwa", 0)]
    with pytest.raises(ConfigError) as err:
        make_controller("d3dwa", SHIPPED["d3dwa"][0], onnx=file)
    one_line(err, file, "give one")
    for method in ("dwa1", "dqdwa"):
        with pytest.raises(ConfigError) as err:
            make_controller(method, onnx=file)
        one_line(err, file, f"method {method!r} does not run a network")


def test_q_values_wants_a_batch_and_call_wants_one_observation(exported) -> None:
    policy, _, _ = load_onnx_policy(exported[("d3dwa", 0)])
    assert policy.q_values(np.zeros((0, 12))).shape == (0, 100)
    with pytest.raises(ValueError, match=r"\(B, 12\)"):
        policy.q_values(np.zeros(12))
    with pytest.raises(ValueError):
        policy(np.zeros(13))


def test_agents_package_reexports_lazily() -> None:
    assert agents.export_onnx is onnx_export.export_onnx
    assert agents.load_onnx_policy is onnx_policy.load_onnx_policy
    assert agents.OnnxGreedyPolicy is onnx_policy.OnnxGreedyPolicy
    assert agents.onnx_metadata is onnx_policy.onnx_metadata
    assert agents.D3QNAgent is D3QNAgent
    assert set(agents.__all__) <= set(dir(agents))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        agents.nope  # noqa: B018


def _python(code: str) -> list[str]:
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, check=True
    )
    return out.stdout.split()


def test_runner_and_agents_package_import_neither_torch_nor_onnxruntime() -> None:
    assert _python(
        """
        import sys
        import d3dwa_bullet.learning.agents
        print('torch' in sys.modules, 'onnxruntime' in sys.modules)
        import d3dwa_bullet.learning.agents.onnx_policy
        print('torch' in sys.modules, 'onnxruntime' in sys.modules)
        """
    ) == ["False", "False", "False", "False"]


def test_an_onnx_controller_drives_where_torch_cannot_be_imported(exported) -> None:
    file = exported[("d3dwa", 0)]
    actions = _python(
        f"""
        import sys
        sys.modules["torch"] = None  # as on a robot without torch: import torch fails
        import numpy as np
        from d3dwa_bullet.controllers import make_controller
        controller = make_controller("d3dwa", onnx={str(file)!r})
        for obs in {OBSERVATIONS.tolist()!r}:
            controller.reset(0)  # each observation a first step: no held decision
            print(controller(np.array(obs))[0])
        print(sys.modules["torch"] is None)
        """
    )
    assert actions == [str(a) for a in GOLDEN_ACTIONS["d3dwa"][0]] + ["True"]
