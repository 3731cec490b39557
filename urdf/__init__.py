"""Package data: the shipped urdf (found through d3dwa_bullet.resources)."""
