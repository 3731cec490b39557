"""A minimal parameter chooser for the d3dwa-bullet testbed (docs/design/external-methods.md).

It keeps DWA III's weights (wp, wc, ws) = (2, 1, 1) and picks the horizon from the nearest
obstacle the observation shows: 2 s when something is within 0.5 m, 5 s when nothing is within
1.5 m, 4 s (DWA III's own) in between. The testbed's DWA then drives with those parameters.
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.planning.actions import ACTIONS_FULL

D_MAX = 3.5
"""The observation divides each sector's nearest range by this, m (docs/design/observation.md)."""


class ClearanceChooser:
    interface_version = 1
    actions = ACTIONS_FULL  # the 100 (wp, wc, ws, tau) actions
    hold = 1  # choose every control step (0.1 s)
    observation = "paper"  # the 12-d state: d_goal, theta_goal, v, w, sector_0..sector_7

    # Action indices found by their tuple, never written by hand.
    SHORT = ACTIONS_FULL.encode((2, 1, 1, 2.0))
    USUAL = ACTIONS_FULL.encode((2, 1, 1, 4.0))  # DWA III: index 59
    LONG = ACTIONS_FULL.encode((2, 1, 1, 5.0))

    def reset(self, episode_seed: int) -> None:
        """Nothing to reset: the rule keeps no state."""

    def choose(self, obs: np.ndarray) -> int:
        """obs: (12,) float64; obs[4:12] the sectors' nearest ranges / 3.5 m, right to left."""
        nearest = float(np.min(obs[4:12])) * D_MAX  # m, from base_link
        if nearest < 0.5:
            return self.SHORT
        if nearest > 1.5:
            return self.LONG
        return self.USUAL
