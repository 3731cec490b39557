"""Kachaka's geometry, in one place: body box, wheels, sensor mounts, planner footprint.

Every length is in metres, in base_link: x forward, y left, z up, origin on the drive-wheel
axis at mid-track, ``AXLE_HEIGHT`` above the floor (docs/design/robot.md#kachaka and
docs/design/planner.md#footprint). The URDF
(``urdf/kachaka.urdf``) states the same numbers for PyBullet; ``tests/test_robot.py`` parses
it and checks it against this module, so the two cannot drift apart.
"""

from __future__ import annotations

BODY_SIZE = (0.387, 0.240, 0.095)
"""Body box (length along x, width along y, height), m."""
BODY_CENTER = (0.0435, 0.0, 0.0475)
"""Centre of the body box in base_link, m (also the base's centre of mass)."""
BODY_CENTER_X = BODY_CENTER[0]
"""How far ahead of base_link the body box is centred, m."""
BODY_HALF_LENGTH = 0.5 * BODY_SIZE[0]
"""Half the body box along x, m."""
BODY_HALF_WIDTH = 0.5 * BODY_SIZE[1]
"""Half the body box along y, m."""

WHEEL_RADIUS = 0.045
"""Drive-wheel radius, m."""
WHEEL_WIDTH = 0.025
"""Drive-wheel width, m."""
TRACK = 0.200
"""Distance between the two drive wheels' centres, m (they sit at y = +-TRACK / 2)."""
AXLE_HEIGHT = WHEEL_RADIUS
"""Height of base_link (the wheel axis) above the floor, m."""

LIDAR_MOUNT = (0.156, 0.0, 0.105)
"""Origin of the 2D lidar (lidar_link) in base_link, m; not rotated."""
IMU_MOUNT = (0.076, -0.066, 0.051)
"""Origin of the IMU (imu_link) in base_link, m; not rotated."""

FOOTPRINT_RADIUS = 0.15
"""Radius r of the planner's collision circles, m (the paper's robot radius)."""
FOOTPRINT_CENTERS_X = (-0.0855, 0.0435, 0.1725)
"""Centres of the planner's three r-circles on the body x axis, m: the body centre and
0.129 m either side, so that their union covers the whole body box."""
