"""Training: a tiny run's outputs, exact resumption, interrupt and failure safety, bad configs."""

from __future__ import annotations

import csv
import json
import os
import signal
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import CheckpointError, ConfigError, TrainingError
from d3dwa_bullet.learning.agents.checkpoint import EXTRA_FILES, load_checkpoint, save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import DQDWAConfig
from d3dwa_bullet.learning.agents.numpy_policy import load_numpy_policy
from d3dwa_bullet.learning.agents.policy import load_policy
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training import (
    TrainConfig,
    Trainer,
    load_train_config,
    make_env,
    read_episodes,
    read_metrics,
    train,
)
from d3dwa_bullet.learning.training.curriculum import Curriculum
from d3dwa_bullet.learning.training.schedule import Cadence
from d3dwa_bullet.planning.actions import ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY
from d3dwa_bullet.resources import configs_dir

TINY_WORLD = """\
name: tiny
group: train
description: open floor, goal 1.2 m ahead, one post off the line
start: [0.0, 0.0, 0.0]
goal: [1.2, 0.0]
obstacles:
  - {type: cylinder, center: [0.6, 0.6], radius: 0.15}
"""
SMALL_AGENT = D3QNConfig(
    hidden=(16, 16), batch_size=8, buffer_size=400, learning_starts=20, eps_decay=100
)


@pytest.fixture
def tiny(tmp_path: Path) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY_WORLD)
    return str(path)


def _config(world: str, **changes) -> TrainConfig:
    base = dict(
        method="d3dwa",
        total_steps=120,
        worlds=(world,),
        generators=(),
        agent=SMALL_AGENT,
        eval_every=0,
        eval_worlds=(world,),
        checkpoint_every=0,
        log_every=20,
        keep="final",
        n_envs=1,  # in this process, so monkeypatched env methods apply
    )
    return TrainConfig(**(base | changes))


def _episodes(out: Path) -> list[dict[str, str]]:
    with (out / "episodes.csv").open(newline="") as fh:
        return [{k: v for k, v in r.items() if k != "wall_time"} for r in csv.DictReader(fh)]


def _weights(path: Path) -> dict[str, torch.Tensor]:
    return torch.load(path / "weights.pt", weights_only=True)


def test_tiny_run_writes_checkpoint_config_and_metrics(tiny: str, tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = _config(tiny, eval_every=60, keep="best")
    summary = train(config, out, progress=False)
    assert summary["status"] == "done" and summary["env_steps"] == 120
    assert summary["train_steps"] > 0 and summary["episodes"] >= 1
    assert load_train_config(out / "config.json") == config
    for name in ("episodes.csv", "metrics.jsonl", "learning_curve.png", "summary.json"):
        assert (out / name).is_file(), name
    assert (out / "learning_curve.png").read_bytes()[:4] == b"\x89PNG"
    tags = {r["tag"] for r in read_metrics(out)}
    assert tags >= {
        "charts/episodic_return",
        "charts/success_rate",
        "charts/epsilon",
        "losses/td_loss",
        "planner/tau",
        "eval/success_rate",
        "eval/mean_q",
        "eval/discounted_return",
    }
    # value calibration of every greedy evaluation: the same figures in the summary's evals
    q = read_metrics(out, "eval/mean_q")
    g = read_metrics(out, "eval/discounted_return")
    assert [r["step"] for r in q] == [r["step"] for r in g] and q[-1]["step"] == 120
    assert all(np.isfinite(r["value"]) for r in q + g)
    assert all(abs(r["value"]) <= 0.5 + 0.01 * 600 for r in g)  # at most the goal + shaping
    hist = read_metrics(out, "planner/tau")[0]["histogram"]
    assert set(hist) == {"2", "3", "4", "5"}
    latest = out / "checkpoints" / "latest"
    assert {p.name for p in latest.iterdir()} >= {"config.json", "replay.npz", "training_state.pt"}
    torch.load(latest / "training_state.pt", weights_only=True)  # tensors and plain values only
    policy_dir = out / "policy"
    assert {p.name for p in policy_dir.iterdir()} == {
        "meta.json",
        "weights.pt",
        "weights.npz",  # the torch-free copy (numpy_policy)
        "config.json",
        "learning_curve.png",
    }
    policy, actions, meta = load_policy(policy_dir, expected_actions=ACTIONS_FULL)
    assert meta["method"] == "d3dwa" and meta["metadata"]["selected"] == "best"
    assert 0 <= policy(np.full(12, 0.5)) < 100
    fast, _, _ = load_numpy_policy(policy_dir, expected_actions=ACTIONS_FULL)
    obs = np.random.default_rng(0).normal(size=(50, 12))
    assert [fast(o) for o in obs] == [policy(o) for o in obs]
    with pytest.raises(ConfigError, match="already holds a training run"):
        train(config, out, progress=False)


def test_route_start_episodes_are_logged_but_not_rated_by_the_curriculum(
    tiny: str, tmp_path: Path
) -> None:
    out = tmp_path / "run"
    config = _config(tiny, total_steps=200, route_start_prob=0.5, curriculum="adaptive")
    trainer = Trainer(config, out)
    trainer.run(progress=False)
    rows = read_episodes(out)
    flags = [r["route_start"] for r in rows]
    assert True in flags and False in flags  # both kinds were drawn
    window = trainer.progress.curriculum.history["tiny"]
    nominal = [int(r["outcome"] == "goal") for r in rows if not r["route_start"]]
    assert list(window) == nominal[-config.curriculum_window :]


def _interrupt_at(monkeypatch: pytest.MonkeyPatch, step: int, sig: int = signal.SIGINT) -> None:
    """Send sig (SIGINT by default) to ourselves from inside the step-th env.step of the next run."""
    original = D3DWAEnv.step
    calls = {"n": 0}

    def step_then_interrupt(self, action):
        calls["n"] += 1
        if calls["n"] == step:
            os.kill(os.getpid(), sig)
        return original(self, action)

    monkeypatch.setattr(D3DWAEnv, "step", step_then_interrupt)


def test_sigterm_stops_at_the_step_boundary_and_saves_latest_as_ctrl_c_does(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`kill PID` (or a cluster ending the job) is a request to stop, not an abort."""
    before = signal.getsignal(signal.SIGTERM)
    with monkeypatch.context() as m:
        _interrupt_at(m, 23, signal.SIGTERM)
        stopped = train(replace(_config(tiny), total_steps=90), tmp_path / "t", progress=False)
    assert stopped["status"] == "interrupted" and stopped["env_steps"] == 23
    latest = json.loads((tmp_path / "t/checkpoints/latest/meta.json").read_text())
    assert latest["env_steps"] == 23
    assert signal.getsignal(signal.SIGTERM) is before  # the caller's handler is back


def test_interrupt_and_resume_continue_exactly(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = _config(tiny)
    a, b = tmp_path / "a", tmp_path / "b"
    done = train(config, a, progress=False)

    with monkeypatch.context() as m:
        _interrupt_at(m, 37)
        stopped = train(replace(config, total_steps=90), b, progress=False)
    assert stopped["status"] == "interrupted" and stopped["env_steps"] == 37
    assert not (b / "policy").exists()
    assert json.loads((b / "checkpoints/latest/meta.json").read_text())["env_steps"] == 37
    part = train(None, b, resume=True, progress=False)  # the run's own config: 90 steps
    assert part["status"] == "done" and part["env_steps"] == 90
    resumed = train(config, b, resume=True, progress=False)  # extend to 120
    assert resumed["env_steps"] == done["env_steps"] == 120
    assert resumed["train_steps"] == done["train_steps"]
    assert resumed["episodes"] == done["episodes"]
    assert _episodes(a) == _episodes(b)
    wa, wb = _weights(a / "policy"), _weights(b / "policy")
    assert all(torch.equal(wa[k], wb[k]) for k in wa)
    ra = np.load(a / "checkpoints/latest/replay.npz")
    rb = np.load(b / "checkpoints/latest/replay.npz")
    for k in ra.files:
        np.testing.assert_array_equal(ra[k], rb[k])
    sa = json.loads((a / "checkpoints/latest/training_state.json").read_text())
    sb = json.loads((b / "checkpoints/latest/training_state.json").read_text())
    assert sa["agent_rng"] == sb["agent_rng"] and sa["epsilon"] == sb["epsilon"]


def test_failure_does_not_clobber_the_checkpoint(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "run"
    config = _config(tiny, total_steps=60, checkpoint_every=30)
    train(config, out, progress=False)
    latest = out / "checkpoints" / "latest"
    before = {p.name: p.read_bytes() for p in latest.iterdir()}
    original = D3DWAEnv.step
    calls = {"n": 0}

    def failing_step(self, action):
        calls["n"] += 1
        if calls["n"] > 55:  # past a due checkpoint (step 90), before the end of the run
            raise RuntimeError("simulated crash")
        return original(self, action)

    monkeypatch.setattr(D3DWAEnv, "step", failing_step)
    with pytest.raises(RuntimeError, match="simulated crash"):
        train(replace(config, total_steps=200), out, resume=True, progress=False)
    assert {p.name: p.read_bytes() for p in latest.iterdir()} == before
    monkeypatch.undo()
    # and the run still resumes from that checkpoint
    assert train(replace(config, total_steps=70), out, resume=True, progress=False)["status"] == (
        "done"
    )


def test_non_finite_weights_are_never_saved(tiny: str, tmp_path: Path) -> None:
    trainer = Trainer(_config(tiny), tmp_path / "run")
    agent = D3QNAgent(ACTIONS_FULL, SMALL_AGENT)
    with torch.no_grad():
        next(agent.online.parameters())[0, 0] = float("nan")
    with pytest.raises(TrainingError, match="NaN"):
        trainer.save_policy("best", agent, {})
    assert not (tmp_path / "run" / "checkpoints" / "best").exists()


def test_resume_refuses_a_changed_config(tiny: str, tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = _config(tiny, total_steps=30)
    train(config, out, progress=False)
    with pytest.raises(ConfigError, match="only total_steps"):
        train(replace(config, seed=5), out, resume=True, progress=False)
    with pytest.raises(ConfigError, match="nothing to resume"):
        train(None, tmp_path / "empty", resume=True, progress=False)


def test_dqdwa_through_the_cli(tiny: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    cfg = tmp_path / "dqdwa.yaml"
    cfg.write_text(
        f"method: dqdwa\ntotal_steps: 80\nworlds: [{tiny}]\ngenerators: []\n"
        f"eval_every: 80\neval_worlds: [{tiny}]\nlog_every: 20\nagent: {{eps_decay: 50}}\n"
    )
    out, export = tmp_path / "run", tmp_path / "policies" / "dqdwa"
    code = main(
        ["train", "--config", str(cfg), "--out", str(out), "--export", str(export), "--json"]
    )
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["status"] == "done" and summary["env_steps"] == 80
    config = load_train_config(out / "config.json")
    assert config.reward_scale == 1.0 and isinstance(config.agent, DQDWAConfig)
    _, actions, meta = load_policy(export, expected_actions=ACTIONS_WEIGHTS_ONLY)
    assert meta["agent"] == "dqdwa" and (export / "config.json").is_file()
    assert "losses/td_loss" in {r["tag"] for r in read_metrics(out)}


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"horizons": ()}, "horizons: the candidate set is empty"),
        ({"weights": (0.0, 1.0)}, "weights: candidate 0.0 must be"),
        ({"weights": (-1.0, 2.0)}, "must be a finite number > 0"),
        (
            {"agent": {"batch_size": 64, "buffer_size": 32}},
            r"buffer_size must be >= batch_size \(64\)",
        ),
        ({"worlds": ("TS1", "US1")}, "evaluation-only"),
        ({"eval_worlds": ("H2",)}, "evaluation-only"),
        ({"method": "dwa3"}, "not a learned method"),
        ({"noise": ("none", "real"), "noise_probs": (1.0,)}, "noise_probs"),
        ({"keep": "best", "eval_every": 0}, "eval_every"),
        ({"total_steps": 0}, "total_steps"),
        ({"agent": {"gamma": 1.0}}, r"gamma must be in \(0, 1\)"),
        ({"agent": {"gamma": 0.0}}, r"gamma must be in \(0, 1\)"),
        ({"agent": {"tau_soft": 0.0}}, r"tau_soft must be in \(0, 1\]"),
        ({"agent": {"tau_soft": 1.5}}, r"tau_soft must be in \(0, 1\]"),
        ({"agent": {"lr": 0.0}}, "lr must be > 0"),
        ({"agent": {"lr": -1e-3}}, "lr must be > 0"),
        ({"agent": DQDWAConfig()}, "needs a D3QNConfig"),
        ({"route_start_prob": 1.5}, "route_start_prob"),
        ({"route_start_span": 1.0}, "route_start_span"),
    ],
)
def test_bad_configs_raise(changes: dict, match: str) -> None:
    # through from_dict, as a YAML file is read: an agent mapping is checked by its config class
    base = {"worlds": ("TS1",), "generators": (), "eval_worlds": ("TS1",)}
    with pytest.raises(ConfigError, match=match):
        TrainConfig.from_dict(base | changes)


def test_bad_config_files_raise(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("method: d3dwa\nlearning_rate: 0.1\n")
    with pytest.raises(ConfigError, match="unknown field.*learning_rate"):
        load_train_config(path)
    path.write_text("method: d3dwa\nagent: {batch_size: 128, buffer_size: 100}\n")
    with pytest.raises(ConfigError, match="bad.yaml.*buffer_size"):
        load_train_config(path)
    path.write_text("method: d3dwa\nhorizons: []\n")
    with pytest.raises(ConfigError, match="empty"):
        load_train_config(path)
    with pytest.raises(ConfigError, match="--method"):
        load_train_config(configs_dir() / "d3dwa.yaml", method="dqdwa")


@pytest.mark.parametrize("method", ["d3dwa", "d3dwa-weights", "d3dwa-dr", "dqdwa"])
def test_committed_configs(method: str) -> None:
    config = load_train_config(configs_dir() / f"{method}.yaml")
    assert config.method == method
    assert config.reward_scale == (1.0 if method == "dqdwa" else 0.01)
    assert all(w.startswith(("TS", "R1-style", "R2-style", "R3-style")) for w in config.eval_worlds)


def test_checkpoint_extra_files_are_digested(tmp_path: Path) -> None:
    agent = D3QNAgent(ACTIONS_FULL, SMALL_AGENT)
    out = save_checkpoint(tmp_path / "c", agent, extra_files={"config.json": b"{}"})
    meta = json.loads((out / "meta.json").read_text())
    assert set(meta["files"]) == {"weights.pt", "config.json"}
    load_checkpoint(out)
    assert "config.json" in EXTRA_FILES
    with pytest.raises(CheckpointError, match="not allowed"):
        save_checkpoint(tmp_path / "d", agent, extra_files={"notes.txt": b""})


def test_cadence_fires_once_per_period_and_never_when_zero() -> None:
    every = Cadence(50)
    fired = [step for step in range(1, 201) if every.take(step)]
    assert fired == [50, 100, 150, 200]
    late = Cadence(50)  # checked only at episode ends: fires at the first one past each period
    assert [step for step in (30, 70, 80, 160, 170, 230) if late.take(step)] == [70, 160, 170, 230]
    never = Cadence(0)
    assert not any(never.take(step) for step in range(1, 1000)) and never.state() is None
    restored = Cadence(50)
    restored.restore(late.state())
    assert restored.next == late.next == 250


def test_adaptive_curriculum_weights_follow_the_failure_rates() -> None:
    curriculum = Curriculum("adaptive", window=2, floor=0.25)
    for task, success in [("a", 0), ("a", 1), ("a", 1), ("b", 0)]:
        curriculum.record(task, success)
    # a: last two both solved -> floor; b: failed -> 1 + floor; c: never tried -> 1 + floor
    assert curriculum.weights(["a", "b", "c"]) == [0.25, 1.25, 1.25]
    again = Curriculum("adaptive", window=2, floor=0.25)
    again.load(curriculum.to_dict())
    assert again.weights(["a", "b", "c"]) == [0.25, 1.25, 1.25]


def test_a_decision_period_run_counts_decisions_and_its_policy_holds(
    tiny: str, tmp_path: Path
) -> None:
    """Beyond the paper: decision_steps 3 makes one env step three control steps; the saved
    policy says so, and the controller built from it, or from its ONNX export, holds each
    action three steps."""
    from d3dwa_bullet.controllers import make_controller
    from d3dwa_bullet.learning.agents.onnx_export import export_onnx

    out = tmp_path / "run"
    summary = train(_config(tiny, total_steps=60, decision_steps=3), out, progress=False)
    assert summary["env_steps"] == 60
    assert load_train_config(out / "config.json").decision_steps == 3
    _, meta = load_checkpoint(out / "policy")
    assert meta["metadata"]["decision_steps"] == 3
    controller = make_controller("d3dwa", policy_path=out / "policy")
    assert controller.hold == 3 and "every 3 control steps" in controller.source
    onnx = export_onnx(out / "policy", tmp_path / "p.onnx").file
    exported = make_controller("d3dwa", onnx=onnx)
    assert exported.hold == 3 and "every 3 control steps" in exported.source


def test_a_recovery_run_trains_and_validates_inside_the_layer(tiny: str, tmp_path: Path) -> None:
    """Beyond the paper: recovery 'nav2' puts the recovery layer around the agent in its
    training envs and its greedy evaluations; config.json keeps it; 'none' is the paper's."""
    config = _config(tiny, total_steps=30, recovery="nav2")
    assert make_env(config).episode_config.recovery is not None
    assert make_env(config, worlds=("R1-style-s1",)).episode_config.recovery is not None
    assert make_env(_config(tiny, total_steps=30)).episode_config.recovery is None
    out = tmp_path / "run"
    train(config, out, progress=False)
    assert load_train_config(out / "config.json").recovery == "nav2"
    # the policy says so, and so does every controller built from it
    assert load_checkpoint(out / "policy")[1]["metadata"]["recovery"] == "nav2"
    from d3dwa_bullet.controllers import make_controller

    assert "recovery layer 'nav2'" in make_controller("d3dwa", policy_path=out / "policy").source
    with pytest.raises(ConfigError, match="TrainConfig.recovery.*'spin'"):
        _config(tiny, recovery="spin")


def test_a_filtered_run_trains_and_validates_behind_the_filter(tiny: str, tmp_path: Path) -> None:
    """Beyond the paper: scan_filter puts the filter chain between the lidar and the agent in
    its training envs and its greedy evaluations; config.json and the policy's metadata keep
    it; 'none' is the paper's."""
    config = _config(tiny, total_steps=30, scan_filter="speckle+median")
    assert make_env(config).episode_config.scan_filter == "speckle+median"
    assert make_env(config, worlds=("R1-style-s1",)).episode_config.scan_filter == "speckle+median"
    assert make_env(_config(tiny, total_steps=30)).episode_config.scan_filter == "none"
    out = tmp_path / "run"
    train(config, out, progress=False)
    assert load_train_config(out / "config.json").scan_filter == "speckle+median"
    assert load_checkpoint(out / "policy")[1]["metadata"]["scan_filter"] == "speckle+median"
    with pytest.raises(ConfigError, match="TrainConfig.scan_filter.*'spek'"):
        _config(tiny, scan_filter="spek")
