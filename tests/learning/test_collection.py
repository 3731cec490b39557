"""Collection on several envs: determinism per (seed, n_envs), exact resume, lost workers.

The lock-step loop must give the same run whether the envs live in worker processes
(``vector: async``) or in this process (``vector: sync``), the same run twice, and the same
run when interrupted and resumed; a worker that dies is a TrainingError that names it, and
the run resumes from its last checkpoint.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from d3dwa_bullet.cli.app import main
from d3dwa_bullet.errors import ConfigError, TrainingError
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.replay import Transition
from d3dwa_bullet.learning.env import D3DWAEnv
from d3dwa_bullet.learning.training import train
from d3dwa_bullet.learning.training.collector import env_seeds
from tests.learning.test_training import TINY_WORLD, _config, _episodes, _weights
from tests.support.hang_guard import within


@pytest.fixture
def tiny(tmp_path: Path) -> str:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY_WORLD)
    return str(path)


def _same_run(a: Path, b: Path) -> None:
    assert _episodes(a) == _episodes(b)
    wa, wb = _weights(a / "policy"), _weights(b / "policy")
    assert all(torch.equal(wa[k], wb[k]) for k in wa)
    ra = np.load(a / "checkpoints/latest/replay.npz")
    rb = np.load(b / "checkpoints/latest/replay.npz")
    assert all(np.array_equal(ra[k], rb[k]) for k in ra.files)


def test_act_batch_draws_as_one_act_per_env() -> None:
    cfg = D3QNConfig(hidden=(8,), eps_start=0.5, eps_end=0.5, seed=3)
    a, b = D3QNAgent(config=cfg), D3QNAgent(config=cfg)
    obs = np.random.default_rng(0).random((7, 12)).astype(np.float32)
    batch = a.act_batch(obs)
    assert batch.tolist() == [b.act(o) for o in obs]
    assert len(set(batch.tolist())) > 1


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_pending_updates_keep_the_ratio_whatever_the_batch(n: int) -> None:
    cfg = D3QNConfig(hidden=(8,), batch_size=4, buffer_size=200, learning_starts=10, train_freq=2)
    agent = D3QNAgent(config=cfg)
    rng = np.random.default_rng(0)
    for _ in range(60 // n):
        for _ in range(n):
            o = rng.random(12).astype(np.float32)
            agent.observe(Transition(o, int(rng.integers(100)), 0.0, o, False))
        agent.update_pending()
    steps = (60 // n) * n
    assert agent.train_steps == steps // 2 - (10 - 1) // 2  # one per multiple of 2 from step 10


def test_env_seeds_keep_the_one_env_seed_first() -> None:
    assert env_seeds(4, 1) == env_seeds(4, 3)[:1]
    assert len(set(env_seeds(4, 3))) == 3


def test_two_envs_in_workers_equal_two_envs_in_process(tiny: str, tmp_path: Path) -> None:
    config = _config(tiny, n_envs=2, total_steps=120, checkpoint_every=40)
    with within(120):
        workers = train(replace(config, vector="async"), tmp_path / "async", progress=False)
    here = train(replace(config, vector="sync"), tmp_path / "sync", progress=False)
    assert workers["env_steps"] == here["env_steps"] == 120
    assert workers["n_envs"] == 2
    _same_run(tmp_path / "async", tmp_path / "sync")
    # and two envs are a different run from one, from the same seed
    one = train(replace(config, n_envs=1), tmp_path / "one", progress=False)
    assert one["env_steps"] == 120
    assert _episodes(tmp_path / "one") != _episodes(tmp_path / "sync")


@pytest.mark.parametrize("n_step", [1, 4])
def test_two_envs_interrupted_and_resumed_equal_uninterrupted(
    n_step: int, tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With n_step 4 the windows of both envs' episodes in progress are in the checkpoint."""
    config = _config(tiny, n_envs=2, vector="sync", total_steps=150, checkpoint_every=30)
    config = replace(config, agent=replace(config.agent, n_step=n_step))
    a, b = tmp_path / "a", tmp_path / "b"
    train(config, a, progress=False)
    original = D3DWAEnv.step
    calls = {"n": 0}

    def step_then_interrupt(self, action):
        calls["n"] += 1
        if calls["n"] == 97:  # mid-episode for both envs
            os.kill(os.getpid(), signal.SIGINT)
        return original(self, action)

    with monkeypatch.context() as m:
        m.setattr(D3DWAEnv, "step", step_then_interrupt)
        stopped = train(config, b, progress=False)
    assert stopped["status"] == "interrupted" and 0 < stopped["env_steps"] < 150
    resumed = train(None, b, resume=True, progress=False)
    assert resumed["status"] == "done" and resumed["env_steps"] == 150
    assert resumed["train_steps"] == train_steps_of(a)
    _same_run(a, b)


def train_steps_of(run: Path) -> int:
    return json.loads((run / "summary.json").read_text())["train_steps"]


def test_resume_with_another_n_envs_is_refused(tiny: str, tmp_path: Path) -> None:
    config = _config(tiny, n_envs=2, vector="sync", total_steps=60)
    train(config, tmp_path / "run", progress=False)
    with pytest.raises((ConfigError, TrainingError), match="n_envs"):
        train(replace(config, n_envs=1, total_steps=90), tmp_path / "run", resume=True,
              progress=False)  # fmt: skip


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_bad_n_envs_names_the_field(tiny: str, bad: object) -> None:
    with pytest.raises(ConfigError, match="n_envs"):
        _config(tiny, n_envs=bad)


def test_cli_refuses_a_negative_n_envs(tiny: str, tmp_path: Path, capsys) -> None:
    assert main(["train", "--method", "d3dwa", "--n-envs", "-2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--n-envs" in err[0]


def test_a_killed_worker_is_a_clear_error_and_the_run_resumes(tiny: str, tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = _config(tiny, n_envs=2, total_steps=3000, checkpoint_every=40)
    latest = out / "checkpoints" / "latest" / "meta.json"
    killed: dict[str, int] = {}

    def kill_a_worker() -> None:
        deadline = time.monotonic() + 90
        while not latest.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = [p for p in multiprocessing.active_children() if p.is_alive()]
        if workers:
            killed["pid"] = workers[0].pid  # type: ignore[assignment]
            os.kill(workers[0].pid, signal.SIGKILL)  # type: ignore[arg-type]

    killer = threading.Thread(target=kill_a_worker, daemon=True)
    killer.start()
    with within(120), pytest.raises(TrainingError) as info:
        train(config, out, progress=False)
    killer.join()
    assert killed, "no worker process was found to kill"
    message = str(info.value)
    assert "worker" in message and "--resume" in message and str(out) in message
    assert latest.exists()
    # the last good checkpoint resumes, here to a short budget
    resumed = train(replace(config, total_steps=_env_steps(latest) + 20), out, resume=True,
                    progress=False)  # fmt: skip
    assert resumed["status"] == "done"


def _env_steps(meta: Path) -> int:
    return int(json.loads(meta.read_text())["env_steps"])


def test_the_progress_bar_says_when_it_is_evaluating(
    tiny: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import io

    from tqdm import tqdm

    import d3dwa_bullet.learning.training.trainer as trainer_module

    stream = io.StringIO()
    monkeypatch.setattr(
        trainer_module, "tqdm", lambda *a, **k: tqdm(*a, **{**k, "file": stream, "mininterval": 0})
    )
    train(_config(tiny, total_steps=60, eval_every=30), tmp_path / "run", progress=True)
    assert "evaluating: 1 greedy episodes" in stream.getvalue()
