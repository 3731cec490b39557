"""Episodes that repeat at every evaluation seed: run once per layout, counted once.

The episode seed reaches an episode by two roads only: the noise model
(``NoiseModel(config, seed)``: none without noise) and :meth:`Controller.reset`, which seeds a
generator only for the uniform choosers (the reference methods ``random``, ``random-weights``,
``random@k``). Nothing else draws: the simulator, the planner, the recovery layer and the scan
filters are functions of what they sense (tests/evaluation/test_repeats.py runs a fixed method
at two seeds with the layer and the filters on and compares the logs). So without noise a
fixed DWA or a learned method's greedy policy runs the same episode, bit for bit, at every
evaluation seed (measured before this module: all 33 DWA III and 165 ``d3dwa`` cells of a
three-seed sweep identical; docs/noise.md).

:func:`repeats_at_every_seed` is the one place that says so. ``evaluate`` runs such an episode
at the first evaluation seed of its (world, method, training seed, noise) only
(:func:`kept_keys`), and every reader counts it once (``results.once_per_layout``), so a directory
written before, which holds the repeats, reads as one written now. Where a test pairs units of
(layout, noise, evaluation seed), the one episode stands for every evaluation seed of its
layout (:mod:`~d3dwa_bullet.evaluation.paired`).

A method outside the registry's fixed and learned methods (a reference method, or any other
name) is taken to draw from the seed: it runs every seed, as before. Pure: no simulator.
"""

from __future__ import annotations

from collections.abc import Iterable

from d3dwa_bullet.method_specs import FIXED, LEARNED

Key = tuple[str, str, int | None, int, str]
"""(world, method, policy_seed, seed, noise): what identifies an episode in a results
directory. policy_seed is the training seed of the policy that drove it (``seed-<k>`` of a
method's policy folder), None for a fixed method or a policy that is not one of a folder's
seeds; it is an empty cell in results.csv. Defined here, below results.py (which imports it
as ``results.Key``), as this module reads keys and results.py this module."""

NOISE_FREE = "none"
"""The noise label of an episode without noise: the profile ``none`` (``make_noise`` gives no
model) and the sweep's shared noise-free baseline. Every explicit noise config of a sweep has
its own label (``slip=0.2``), so this label never hides a noise source."""
ONCE_NOTE = (
    "Deterministic without noise: run once per layout. Under the profile `none` a fixed "
    "method or a learned (greedy) policy draws nothing from the episode seed, so it runs the "
    "first evaluation seed only and each layout counts once; the random choosers run every "
    "seed."
)
"""What a page says when some of its noise-free episodes ran once for several seeds."""


def repeats_at_every_seed(method: str, noise: str) -> bool:
    """True when an episode of ``method`` under noise label ``noise`` is the same at every
    evaluation seed: no noise, and a fixed method or a learned method's greedy policy (no
    random number drawn; the recovery layer and the scan filters draw none either)."""
    return noise == NOISE_FREE and (method in FIXED or method in LEARNED)


def kept_keys(keys: Iterable[Key]) -> list[Key]:
    """keys without the repeats: of the keys that :func:`repeats_at_every_seed`, only the one
    with the lowest evaluation seed of its (world, method, training seed, noise); the others
    all kept, in their order."""
    keys = list(keys)
    first: dict[tuple[str, str, int | None, str], int] = {}
    for world, method, policy_seed, seed, noise in keys:
        if repeats_at_every_seed(method, noise):
            group = (world, method, policy_seed, noise)
            first[group] = min(first.get(group, seed), seed)
    return [
        k
        for k in keys
        if not repeats_at_every_seed(k[1], k[4]) or first[(k[0], k[1], k[2], k[4])] == k[3]
    ]
