"""Randomisation profiles and per-episode noise sampling (docs/design/noise.md#profiles).

>>> from randomization import load_profile, episode_noise
>>> noise = episode_noise(load_profile("real"), seed=7)   # a NoiseModel for one episode
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.sim.noise import NoiseModel
from randomization.profiles import (
    PROFILE_VERSION,
    Profile,
    list_profiles,
    load_profile,
    profile_from_dict,
)


def episode_noise(profile: Profile, seed: int) -> NoiseModel:
    """Sample ``profile`` and build the episode's NoiseModel, both from the one episode seed.

    The seed is split in two independent streams: one samples the profile's distributions,
    the other seeds the NoiseModel's per-model streams. ``NoiseModel(profile.sample(...), seed)``
    by hand works too; this just fixes the convention.
    """
    profile_seq, model_seq = np.random.SeedSequence(seed).spawn(2)
    config = profile.sample(np.random.default_rng(profile_seq))
    return NoiseModel(config, model_seq)


__all__ = [
    "PROFILE_VERSION",
    "Profile",
    "episode_noise",
    "list_profiles",
    "load_profile",
    "profile_from_dict",
]
