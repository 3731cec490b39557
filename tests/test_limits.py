"""The limits of d3dwa_bullet.limits, checked where values are parsed (issue 24)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from d3dwa_bullet import limits
from d3dwa_bullet.errors import ConfigError, ProfileError
from d3dwa_bullet.learning.agents.d3qn import D3QNConfig
from d3dwa_bullet.learning.agents.replay import ReplayBuffer, check_replay_memory, replay_bytes
from d3dwa_bullet.limits import MAX_SEEDS, Limit, check_processes, check_weights, max_processes
from d3dwa_bullet.loading import load_yaml
from d3dwa_bullet.resources import profiles_dir
from d3dwa_bullet.seed_dirs import parse_seeds
from randomization.profiles import profile_from_dict


def test_a_limit_names_the_option_the_value_the_limit_and_why():
    with pytest.raises(ConfigError) as err:
        Limit(10, "ten is plenty").check("--things", 11, "things")
    assert str(err.value) == "--things: 11 things is over the limit of 10 things (ten is plenty)"
    Limit(10, "ten is plenty").check("--things", 10)  # inclusive
    with pytest.raises(ConfigError):
        Limit(10.0, "x").check("--t", float("nan"))


def test_a_huge_seed_range_is_refused_before_it_is_expanded():
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=r"--seeds: 100000000000 seeds is over the limit"):
        parse_seeds("0-99999999999")
    assert time.perf_counter() - start < 5.0  # nothing the size of the range was built
    top = int(MAX_SEEDS.value)
    assert len(parse_seeds(f"0-{top - 1}")) == top
    with pytest.raises(ConfigError, match="--policy-seeds: .* seeds is over the limit"):
        parse_seeds(f"0-{top - 2},{top},{top + 1}", "--policy-seeds")
    with pytest.raises(ConfigError, match="--seeds: 4294967296 is over the limit of 4294967295"):
        parse_seeds("4294967296")


def test_processes_are_bounded_by_the_cores_of_this_machine():
    check_processes("--workers", max_processes())
    with pytest.raises(ConfigError, match=r"--n-envs: .* processes is over the limit .* per core"):
        check_processes("--n-envs", max_processes() + 1)


@pytest.mark.parametrize(
    "weights, why",
    [
        ([1e308, 1e308], "finite sum"),
        ([float("inf"), 1.0], "finite numbers"),
        ([float("nan"), 1.0], "finite numbers"),
        ([-1.0, 2.0], "finite numbers"),
        ([0.0, 0.0], "finite sum > 0"),
        ([True, 1.0], "finite numbers"),
    ],
)
def test_weights_must_be_finite_with_a_finite_positive_sum(weights, why):
    with pytest.raises(ConfigError, match=why):
        check_weights("noise_probs", weights)


def test_profile_choice_weights_that_overflow_their_sum_are_refused():
    profile = load_yaml(profiles_dir() / "paper.yaml", ProfileError)
    lidar = profile["params"]["lidar"]
    lidar["dropout_prob"] = {"choice": [0.0, 0.1], "weights": [1e308, 1e308]}
    with pytest.raises(ProfileError, match=r"w\.yaml: .*finite sum > 0"):
        profile_from_dict(profile, "w.yaml")
    lidar["dropout_prob"]["weights"] = [1e300, 3e300]  # large but summable: fine
    choice = profile_from_dict(profile, "w.yaml").params["lidar"]["dropout_prob"]
    assert choice.weights == pytest.approx((0.25, 0.75))


def test_a_replay_capacity_past_the_limit_is_refused_in_the_config():
    with pytest.raises(ConfigError, match="buffer_size"):
        D3QNConfig(buffer_size=10**12)


def test_a_replay_buffer_larger_than_memory_allows_is_refused_before_allocation(monkeypatch):
    monkeypatch.setattr(limits, "available_memory", lambda: 100 * 2**20)  # 100 MiB free
    allocated = []
    monkeypatch.setattr(np, "zeros", lambda *a, **k: allocated.append(a))
    need = replay_bytes(1_000_000, 12)
    assert need > 50 * 2**20
    with pytest.raises(ConfigError, match=r"agent\.buffer_size: 1000000 transitions need"):
        check_replay_memory(1_000_000, 12, "agent.buffer_size")
    with pytest.raises(ConfigError, match="of memory available"):
        ReplayBuffer(1_000_000, 12)
    assert allocated == []
