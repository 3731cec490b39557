"""Learning agents that pick the planner's action: D3QN (d3dwa, d3dwa-weights) and tabular DQDWA.

Modules: ``network`` (dueling Q-network), ``replay`` (uniform replay), ``d3qn`` (the D3QN
algorithm), ``dqdwa`` (tabular baseline), ``checkpoint`` (save/load), ``training_state``
(what a checkpoint adds to resume training exactly), ``policy`` (fast greedy policies for
evaluation), ``onnx_export`` (a D3QN checkpoint -> an ONNX file), ``onnx_policy`` (the
greedy policy of an ONNX file, run by onnxruntime without torch), ``policy_terms`` (the
decision period and training recovery layer either records, checked alike) and ``barn_record``
(the BARN worlds a policy trained on, as its meta.json records them).

The names below are re-exported lazily, each imported on first access: ``onnx_policy`` must
stay importable where torch is not installed (a robot's computer), and onnxruntime and onnx
are an optional extra (``robot``) that ``import d3dwa_bullet.learning.agents`` must not need.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from d3dwa_bullet.lazy import lazy_exports

if TYPE_CHECKING:
    from d3dwa_bullet.learning.agents.checkpoint import load_checkpoint, save_checkpoint
    from d3dwa_bullet.learning.agents.d3qn import D3QNAgent, D3QNConfig
    from d3dwa_bullet.learning.agents.dqdwa import Discretisation, DQDWAAgent, DQDWAConfig
    from d3dwa_bullet.learning.agents.network import DuelingQNetwork
    from d3dwa_bullet.learning.agents.onnx_export import export_onnx
    from d3dwa_bullet.learning.agents.onnx_policy import (
        OnnxGreedyPolicy,
        load_onnx_policy,
        onnx_metadata,
    )
    from d3dwa_bullet.learning.agents.policy import Policy, greedy_policy, load_policy
    from d3dwa_bullet.learning.agents.replay import ReplayBatch, ReplayBuffer, Transition

_HOMES = {
    "load_checkpoint": "d3dwa_bullet.learning.agents.checkpoint",
    "save_checkpoint": "d3dwa_bullet.learning.agents.checkpoint",
    "D3QNAgent": "d3dwa_bullet.learning.agents.d3qn",
    "D3QNConfig": "d3dwa_bullet.learning.agents.d3qn",
    "DQDWAAgent": "d3dwa_bullet.learning.agents.dqdwa",
    "DQDWAConfig": "d3dwa_bullet.learning.agents.dqdwa",
    "Discretisation": "d3dwa_bullet.learning.agents.dqdwa",
    "DuelingQNetwork": "d3dwa_bullet.learning.agents.network",
    "export_onnx": "d3dwa_bullet.learning.agents.onnx_export",
    "OnnxGreedyPolicy": "d3dwa_bullet.learning.agents.onnx_policy",
    "load_onnx_policy": "d3dwa_bullet.learning.agents.onnx_policy",
    "onnx_metadata": "d3dwa_bullet.learning.agents.onnx_policy",
    "Policy": "d3dwa_bullet.learning.agents.policy",
    "greedy_policy": "d3dwa_bullet.learning.agents.policy",
    "load_policy": "d3dwa_bullet.learning.agents.policy",
    "ReplayBatch": "d3dwa_bullet.learning.agents.replay",
    "ReplayBuffer": "d3dwa_bullet.learning.agents.replay",
    "Transition": "d3dwa_bullet.learning.agents.replay",
}
"""Re-exported name -> the module that defines it."""

__all__ = [
    "D3QNAgent",
    "D3QNConfig",
    "DQDWAAgent",
    "DQDWAConfig",
    "Discretisation",
    "DuelingQNetwork",
    "OnnxGreedyPolicy",
    "Policy",
    "ReplayBatch",
    "ReplayBuffer",
    "Transition",
    "export_onnx",
    "greedy_policy",
    "load_checkpoint",
    "load_onnx_policy",
    "load_policy",
    "onnx_metadata",
    "save_checkpoint",
]


# Imported on first access: most of these modules need torch, the onnx ones an optional extra.
__getattr__, __dir__ = lazy_exports(globals(), _HOMES)
