"""The shipped DQN zip as a d3dwa-bullet parameter chooser (interface version 1).

The zip records no env id or wrappers, so the terms it was trained under are declared here,
and ``train.py`` trains with these very values: the full 100-action set, a decision every
control step, the paper's 12-d observation.
"""

from __future__ import annotations

from pathlib import Path

from d3dwa_bullet.external.sb3_zip import SB3Chooser
from d3dwa_bullet.planning.actions import ACTIONS_FULL

MODEL = Path(__file__).with_name("dqn_d3dwa.zip")


class SB3DQN(SB3Chooser):
    """Greedy over the DQN's Q-values, read from the zip without unpickling it."""

    model_file = MODEL
    actions = ACTIONS_FULL
    hold = 1
    observation = "paper"
