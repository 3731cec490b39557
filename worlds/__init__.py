"""Package data: the shipped worlds (found through d3dwa_bullet.resources)."""
