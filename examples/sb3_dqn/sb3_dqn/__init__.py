"""An SB3 DQN trained on d3dwa_bullet/D3DWA-v0, an external parameter chooser of d3dwa-bullet."""

from sb3_dqn.chooser import SB3DQN

__all__ = ["SB3DQN"]
__version__ = "0.1.0"
