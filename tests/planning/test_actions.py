"""The discrete action table: sizes, contents, order, round trips and validation."""

from __future__ import annotations

import itertools

import pytest

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.planning.actions import (
    ACTIONS_FULL,
    ACTIONS_WEIGHTS_ONLY,
    FIXED_HORIZON,
    ActionSet,
    PlannerAction,
)


@pytest.mark.parametrize(
    ("actions", "size", "horizons"),
    [(ACTIONS_FULL, 100, (2.0, 3.0, 4.0, 5.0)), (ACTIONS_WEIGHTS_ONLY, 25, (4.0,))],
)
def test_sizes_match_paper_formula(
    actions: ActionSet, size: int, horizons: tuple[float, ...]
) -> None:
    n_w = len(actions.weights)
    assert actions.size == len(actions) == size == (n_w**3 - n_w + 1) * len(horizons)
    assert actions.horizons == horizons
    assert actions.weights == (1.0, 2.0, 3.0)
    assert actions.n_triples == 25
    assert len(set(actions.actions)) == size


@pytest.mark.parametrize("actions", [ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY])
def test_no_duplicate_weight_ratios(actions: ActionSet) -> None:
    for tau in actions.horizons:
        ratios = set()
        for a in actions.actions:
            if a.tau == tau:
                s = a.wp + a.wc + a.ws
                ratios.add((round(a.wp / s, 12), round(a.wc / s, 12), round(a.ws / s, 12)))
        assert len(ratios) == actions.n_triples


@pytest.mark.parametrize("tau", [2.0, 3.0, 4.0, 5.0])
def test_uniform_triples(tau: float) -> None:
    present = set(ACTIONS_FULL.actions)
    assert PlannerAction(1.0, 1.0, 1.0, tau) in present
    assert PlannerAction(2.0, 2.0, 2.0, tau) not in present
    assert PlannerAction(3.0, 3.0, 3.0, tau) not in present


def test_order_is_horizon_major_then_lexicographic() -> None:
    triples = [
        t for t in itertools.product((1.0, 2.0, 3.0), repeat=3) if len(set(t)) > 1 or t[0] == 1.0
    ]
    expected = [PlannerAction(*t, tau) for tau in (2.0, 3.0, 4.0, 5.0) for t in triples]
    assert list(ACTIONS_FULL.actions) == expected
    assert ACTIONS_FULL.decode(0) == PlannerAction(1.0, 1.0, 1.0, 2.0)
    assert ACTIONS_FULL.decode(1) == PlannerAction(1.0, 1.0, 2.0, 2.0)
    assert ACTIONS_FULL.decode(24) == PlannerAction(3.0, 3.0, 2.0, 2.0)
    assert ACTIONS_FULL.decode(25) == PlannerAction(1.0, 1.0, 1.0, 3.0)
    assert ACTIONS_FULL.decode(99) == PlannerAction(3.0, 3.0, 2.0, 5.0)
    # Weights-only numbering equals the triple numbering inside each full horizon block.
    for i in range(ACTIONS_FULL.size):
        full = ACTIONS_FULL.decode(i)
        assert ACTIONS_WEIGHTS_ONLY.decode(i % 25)[:3] == full[:3]
        assert full.tau == ACTIONS_FULL.horizons[i // 25]


@pytest.mark.parametrize("actions", [ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY])
def test_encode_decode_round_trip(actions: ActionSet) -> None:
    for i in range(actions.size):
        assert actions.encode(actions.decode(i)) == i
    for a in actions.actions:
        assert actions.decode(actions.encode(a)) == a
    table = actions.table()
    assert table.shape == (actions.size, 4)
    assert [tuple(row) for row in table] == [tuple(a) for a in actions.actions]


@pytest.mark.parametrize(
    ("name", "action"),
    [("dwa1", (1, 1, 2, 4)), ("dwa2", (1, 2, 1, 4)), ("dwa3", (2, 1, 1, 4))],
)
def test_fixed_baselines_are_in_both_sets(name: str, action: tuple[int, ...]) -> None:
    i = ACTIONS_WEIGHTS_ONLY.encode(action)
    assert ACTIONS_WEIGHTS_ONLY.decode(i) == PlannerAction(*map(float, action))
    assert ACTIONS_FULL.encode(action) == 2 * 25 + i  # tau = 4 s is the third block
    assert FIXED_HORIZON == 4.0


def test_uniform_triple_encodes_to_retained_one() -> None:
    assert ACTIONS_FULL.encode((3, 3, 3, 5)) == ACTIONS_FULL.encode((1, 1, 1, 5)) == 75


@pytest.mark.parametrize("bad", [(1, 1, 2, 6), (1, 1, 4, 4), (0.5, 0.5, 0.5, 4)])
def test_encode_unknown_raises(bad: tuple[float, ...]) -> None:
    with pytest.raises(ConfigError, match="not in the action set"):
        ACTIONS_FULL.encode(bad)


@pytest.mark.parametrize("bad", [-1, 100, 2.5])
def test_decode_out_of_range(bad: float) -> None:
    with pytest.raises(ConfigError, match="out of range"):
        ACTIONS_FULL.decode(bad)


@pytest.mark.parametrize(
    ("weights", "horizons", "match"),
    [
        ((1, 2, 3), (), "horizons: the candidate set is empty"),
        ((), (4,), "weights: the candidate set is empty"),
        ((0, 1, 2), (4,), "candidate 0.0"),
        ((1, -2), (4,), "candidate -2.0"),
        ((1, 2), (-4.0,), "candidate -4.0"),
        ((1, 2, 2), (4,), "duplicate candidate 2.0"),
        ((1, 2), (4, 4), "duplicate candidate 4.0"),
        ((2, 1), (4,), "increasing"),
        ((1, float("nan")), (4,), "candidate nan"),
    ],
)
def test_validation(weights: tuple, horizons: tuple, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        ActionSet(weights, horizons)


@pytest.mark.parametrize("actions", [ACTIONS_FULL, ACTIONS_WEIGHTS_ONLY, ActionSet((1, 2), (1.5,))])
def test_dict_round_trip(actions: ActionSet) -> None:
    data = actions.to_dict()
    assert data["size"] == actions.size
    back = ActionSet.from_dict(data)
    assert back == actions and back.actions == actions.actions
    assert hash(back) == hash(actions)


def test_from_dict_rejects_inconsistent_size() -> None:
    with pytest.raises(ConfigError, match="size=99"):
        ActionSet.from_dict({"weights": [1, 2, 3], "horizons": [2, 3, 4, 5], "size": 99})
    with pytest.raises(ConfigError, match="lacks"):
        ActionSet.from_dict({"weights": [1, 2, 3]})


def test_weights_only_helper() -> None:
    assert ACTIONS_FULL.weights_only() == ACTIONS_WEIGHTS_ONLY
    assert ACTIONS_FULL != ACTIONS_WEIGHTS_ONLY
