"""d3dwa-bullet: a PyBullet sim-to-real testbed for D3DWA on a Kachaka robot.

Importing the package registers the Gymnasium environment ``d3dwa_bullet/D3DWA-v0`` (by
its entry-point string, so nothing heavy is imported here).
"""

import gymnasium

__version__ = "0.1.0"

ENV_ID = "d3dwa_bullet/D3DWA-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=ENV_ID, entry_point="d3dwa_bullet.learning.env:D3DWAEnv", disable_env_checker=False
    )
