"""Package data: the shipped policies (found through d3dwa_bullet.resources)."""
