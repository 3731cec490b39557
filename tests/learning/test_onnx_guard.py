"""A hostile ONNX file is refused, never trusted (issue 31): its graph must be the kind the
exporter writes (operators, weights inside the file, bounded memory and work per inference),
and no action is ever chosen from Q-values that are not finite numbers. Every model here is
made by hand with ``onnx.helper`` and is a few kB."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.learning.agents.onnx_graph import ALLOWED_OPS, OPSET, GraphCost
from d3dwa_bullet.learning.agents.onnx_policy import (
    OnnxGreedyPolicy,
    load_onnx_policy,
    metadata_props,
    onnx_metadata,
)
from d3dwa_bullet.planning.actions import ACTIONS_FULL
from tests.support.cli import refused

N_ACTIONS = ACTIONS_FULL.size
OBS_DIM = 12
SECTORS = slice(4, 12)  # the paper observation's sector entries
PROPS = metadata_props("d3dwa", "paper", ACTIONS_FULL, {"checkpoint": "hand-made"})
EXPECT = {"expected_actions": ACTIONS_FULL, "expected_observation": ("paper", "test")}


def weight(name: str, values) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(values, dtype=np.float32), name)


def model(nodes, weights, extra_opsets=(), graphs=None) -> onnx.ModelProto:
    """A policy-shaped model: obs (batch, 12) float -> q (batch, 100) float, our metadata."""
    obs = helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["batch", OBS_DIM])
    q = helper.make_tensor_value_info("q", TensorProto.FLOAT, ["batch", N_ACTIONS])
    graph = graphs or helper.make_graph(nodes, "hostile", [obs], [q], weights)
    opsets = [helper.make_opsetid("", OPSET), *extra_opsets]
    made = helper.make_model(graph, opset_imports=opsets, ir_version=8)
    helper.set_model_props(made, PROPS)
    return made


def save(tmp_path: Path, made: onnx.ModelProto, name: str = "policy.onnx") -> Path:
    path = tmp_path / name
    path.write_bytes(made.SerializeToString())
    return path


def nan_on_a_free_sector() -> onnx.ModelProto:
    """Q = h - h with h = inf where a sector entry is exactly 1.0 (a free sector, as every
    real observation in an open room has), else 0: finite on the all-zero observation and on
    uniform samples in [0, 1), NaN on what the robot really sees. Allowed operators only."""
    below_one = np.float32(1.0) - np.float32(2.0**-24)
    pick = np.zeros((8, OBS_DIM), dtype=np.float32)
    pick[np.arange(8), np.arange(4, 12)] = 1e30
    bias = np.full(8, -np.float32(1e30) * below_one, dtype=np.float32)
    nodes = [
        helper.make_node("Gemm", ["obs", "pick", "bias"], ["edge"], transB=1),
        helper.make_node("Relu", ["edge"], ["over"]),
        helper.make_node("Gemm", ["over", "blow"], ["h"], transB=1),
        helper.make_node("Sub", ["h", "h"], ["q"]),
    ]
    blow = np.full((N_ACTIONS, 8), 1e30, dtype=np.float32)
    return model(nodes, [weight("pick", pick), weight("bias", bias), weight("blow", blow)])


def test_nan_q_values_on_a_real_observation_are_an_error_not_action_0(tmp_path):
    file = save(tmp_path, nan_on_a_free_sector())
    policy, _, _ = load_onnx_policy(file, **EXPECT)  # finite on zeros and on the samples
    quiet = np.full(OBS_DIM, 0.5)
    assert policy(quiet) == 0
    seen = quiet.copy()
    seen[SECTORS.start + 3] = 1.0
    with pytest.raises(CheckpointError) as err:
        policy(seen)
    message = str(err.value)
    assert "\n" not in message and str(file) in message and "NaN or inf" in message
    with pytest.raises(CheckpointError, match="NaN or inf"):
        policy.q_values(np.stack([quiet, seen]))


def test_the_cli_stops_with_one_line_on_a_policy_that_returns_nan(capsys, tmp_path):
    file = save(tmp_path, nan_on_a_free_sector())
    line = refused(capsys, "run", "--world", "R1", "--method", "d3dwa", "--onnx", file)
    assert str(file) in line and "Q-values are NaN or inf for observation" in line


def test_a_policy_that_fails_only_when_it_runs_is_one_line(tmp_path):
    """Passes the graph check for one observation; a batch of any other size than 1 or 2
    cannot broadcast (2, 1) against (B, 1): the runtime fails, the caller gets one line."""
    nodes = [
        helper.make_node("ReduceMean", ["obs"], ["m"], axes=[1], keepdims=1),
        helper.make_node("Add", ["m", "two"], ["m2"]),
        helper.make_node("ReduceMean", ["m2"], ["m1"], axes=[0], keepdims=1),
        helper.make_node("Gemm", ["m1", "w"], ["q"], transB=1),
    ]
    file = save(
        tmp_path,
        model(nodes, [weight("two", [[0.0], [1.0]]), weight("w", np.ones((N_ACTIONS, 1)))]),
    )
    with pytest.raises(CheckpointError) as err:
        load_onnx_policy(file, **EXPECT)  # the load probe runs a batch of 65
    message = str(err.value)
    assert "\n" not in message and str(file) in message
    assert "the policy failed to run on 65 observation(s)" in message


class Failing:
    """An onnxruntime session whose run raises, as a graph that fails on some input does."""

    def run(self, outputs, feed):
        raise RuntimeError("Non-zero status code returned while running Add node.\nline two")


def test_a_runtime_failure_at_a_decision_is_one_line():
    cost = GraphCost(weights=0, per_row=1, macs=1)
    policy = OnnxGreedyPolicy(Failing(), OBS_DIM, N_ACTIONS, "p.onnx", cost)
    with pytest.raises(CheckpointError) as err:
        policy(np.zeros(OBS_DIM))
    assert str(err.value).startswith("p.onnx: the policy failed to run on 1 observation(s)")
    assert "\n" not in str(err.value)


def _loop_model() -> onnx.ModelProto:
    """q = Gemm(Loop(2^40 times: identity)(obs)): a valid graph that would run for days."""
    body = helper.make_graph(
        [
            helper.make_node("Identity", ["cond_in"], ["cond_out"]),
            helper.make_node("Identity", ["x_in"], ["x_out"]),
        ],
        "body",
        [
            helper.make_tensor_value_info("i", TensorProto.INT64, []),
            helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
            helper.make_tensor_value_info("x_in", TensorProto.FLOAT, None),
        ],
        [
            helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
            helper.make_tensor_value_info("x_out", TensorProto.FLOAT, None),
        ],
    )
    nodes = [
        helper.make_node("Loop", ["trips", "go", "obs"], ["looped"], body=body),
        helper.make_node("Gemm", ["looped", "w"], ["q"], transB=1),
    ]
    weights = [
        numpy_helper.from_array(np.array(2**40, dtype=np.int64), "trips"),
        numpy_helper.from_array(np.array(True), "go"),
        weight("w", np.ones((N_ACTIONS, OBS_DIM))),
    ]
    return model(nodes, weights)


def _expand_model() -> onnx.ModelProto:
    """q = Gemm(Expand(obs, [2^20, 2^20, 12])): 48 TB the moment it runs."""
    nodes = [
        helper.make_node("Expand", ["obs", "shape"], ["big"]),
        helper.make_node("ReduceMean", ["big"], ["small"], axes=[0], keepdims=0),
        helper.make_node("Gemm", ["small", "w"], ["q"], transB=1),
    ]
    shape = numpy_helper.from_array(np.array([2**20, 2**20, OBS_DIM], dtype=np.int64), "shape")
    return model(nodes, [shape, weight("w", np.ones((N_ACTIONS, OBS_DIM)))])


def _broadcast_model() -> onnx.ModelProto:
    """Allowed operators only: (1, 8192) + (8192, 1) is 67 million floats per inference."""
    n = 8192
    nodes = [
        helper.make_node("Add", ["row", "column"], ["square"]),
        helper.make_node("ReduceMean", ["square"], ["mean"], axes=[0, 1], keepdims=1),
        helper.make_node("Gemm", ["obs", "w"], ["g"], transB=1),
        helper.make_node("Add", ["g", "mean"], ["q"]),
    ]
    weights = [weight("row", np.ones((1, n))), weight("column", np.ones((n, 1)))]
    return model(nodes, [*weights, weight("w", np.ones((N_ACTIONS, OBS_DIM)))])


def _work_model() -> onnx.ModelProto:
    """Allowed operators only: a (2000, 12) x (12, 2000) product, 48 million multiply-adds
    for one observation from 100 kB of weights."""
    nodes = [
        helper.make_node("Add", ["obs", "rows"], ["tall"]),
        helper.make_node("Gemm", ["tall", "wide"], ["square"]),
        helper.make_node("ReduceMean", ["square"], ["mean"], axes=[0, 1], keepdims=1),
        helper.make_node("Gemm", ["obs", "w"], ["g"], transB=1),
        helper.make_node("Add", ["g", "mean"], ["q"]),
    ]
    weights = [weight("rows", np.zeros((2000, 1))), weight("wide", np.ones((OBS_DIM, 2000)))]
    return model(nodes, [*weights, weight("w", np.ones((N_ACTIONS, OBS_DIM)))])


def _contrib_model() -> onnx.ModelProto:
    """A node named Gemm in another domain: not the operator the allowlist means."""
    node = helper.make_node("Gemm", ["obs", "w"], ["q"], transB=1, domain="com.microsoft")
    return model(
        [node],
        [weight("w", np.ones((N_ACTIONS, OBS_DIM)))],
        extra_opsets=[helper.make_opsetid("com.microsoft", 1)],
    )


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (_loop_model, "operator 'Loop' is not one an exported policy uses"),
        (_expand_model, "operator 'Expand' is not one an exported policy uses"),
        (_broadcast_model, "floats is over the limit of 16777216 floats"),
        (_work_model, "multiply-adds is over the limit of 33554432"),
        (_contrib_model, "it imports opsets"),
    ],
    ids=["loop", "expand", "broadcast", "work", "contrib-domain"],
)
def test_graphs_an_export_never_writes_are_refused_before_they_run(tmp_path, make, says):
    file = save(tmp_path, make())
    assert file.stat().st_size < 200_000
    started = time.perf_counter()
    for load in (lambda: load_onnx_policy(file, **EXPECT), lambda: onnx_metadata(file)):
        with pytest.raises(CheckpointError) as err:
            load()
        message = str(err.value)
        assert "\n" not in message and str(file) in message and says in message, message
        assert "refused before running" in message
    assert time.perf_counter() - started < 5.0


def test_the_allowlist_is_what_the_exporter_writes():
    assert set(ALLOWED_OPS) == {"Gemm", "Relu", "ReduceMean", "Add", "Sub"}


def test_external_data_is_refused_not_read_from_the_working_directory(tmp_path, monkeypatch):
    """A file naming its weights' data 'weights.bin' would read whatever file of that name
    sits in the directory the command runs in."""
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    np.ones((N_ACTIONS, OBS_DIM), dtype=np.float32).tofile(elsewhere / "weights.bin")
    w = weight("w", np.zeros((N_ACTIONS, OBS_DIM)))
    onnx.external_data_helper.set_external_data(w, location="weights.bin")
    w.ClearField("raw_data")
    w.data_location = TensorProto.EXTERNAL
    made = model([helper.make_node("Gemm", ["obs", "w"], ["q"], transB=1)], [w])
    folder = tmp_path / "models"
    folder.mkdir()
    file = save(folder, made)
    monkeypatch.chdir(elsewhere)
    for load in (lambda: load_onnx_policy(file, **EXPECT), lambda: onnx_metadata(file)):
        with pytest.raises(CheckpointError) as err:
            load()
        message = str(err.value)
        assert "\n" not in message and str(file) in message
        assert "weight 'w' is external data" in message
