"""Package data: the shipped configs (found through d3dwa_bullet.resources)."""
