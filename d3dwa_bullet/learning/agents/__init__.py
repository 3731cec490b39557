"""Learning agents that pick the planner's action: D3QN (d3dwa, d3dwa-weights) and tabular DQDWA.

Modules: ``network`` (dueling Q-network), ``replay`` (uniform replay), ``d3qn`` (the D3QN
algorithm), ``dqdwa`` (tabular baseline), ``checkpoint`` (save/load), ``training_state``
(what a checkpoint adds to resume training exactly), ``policy`` (fast greedy policies for
evaluation).
"""

from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint, save_checkpoint
from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
from d3dwa_bullet.learning.agents.dqdwa import Discretisation, DQDWAAgent, DQDWAConfig
from d3dwa_bullet.learning.agents.network import DuelingQNetwork
from d3dwa_bullet.learning.agents.policy import Policy, greedy_policy, load_policy
from d3dwa_bullet.learning.agents.replay import ReplayBatch, ReplayBuffer, Transition

__all__ = [
    "D3QNAgent",
    "D3QNConfig",
    "DQDWAAgent",
    "DQDWAConfig",
    "Discretisation",
    "DuelingQNetwork",
    "Policy",
    "ReplayBatch",
    "ReplayBuffer",
    "Transition",
    "greedy_policy",
    "load_checkpoint",
    "load_policy",
    "save_checkpoint",
]
