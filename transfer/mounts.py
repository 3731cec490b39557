"""Where a bag's lidar and IMU sit on the robot body, found from the bag's tf tree.

The body frame is the first of ``BASE_FRAMES`` the tf tree connects to the sensor's frame.
A lidar without such a transform is taken at Kachaka's mount; an IMU without one is taken
as aligned with the body.
"""

from __future__ import annotations

import numpy as np

from d3dwa_bullet.robot import LIDAR_MOUNT
from d3dwa_bullet.sim.scan import Pose2D
from transfer.transforms import TransformTree, pose2d_from_matrix

#: Frames tried, in order, as the robot body frame when looking up the lidar mount.
BASE_FRAMES = ("base_link", "base_footprint")
#: Kachaka's lidar mount in base_link (d3dwa_bullet.robot), used when a bag has no transform.
KACHAKA_LIDAR_MOUNT = Pose2D(LIDAR_MOUNT[0], LIDAR_MOUNT[1], 0.0)


def find_lidar_mount(tree: TransformTree, scan_frame: str) -> tuple[Pose2D, bool, str]:
    """The lidar frame's pose in the body frame: (pose, upside down, how it was found)."""
    if scan_frame in BASE_FRAMES:
        return Pose2D(), False, f"scan frame is {scan_frame!r}"
    for base in BASE_FRAMES:
        mat = tree.lookup(base, scan_frame)
        if mat is not None:
            pose, flipped = pose2d_from_matrix(mat)
            chain = " -> ".join(tree.path(base, scan_frame) or [])
            kind = (
                "static"
                if all(k in tree.static for k in _chain_keys(tree, base, scan_frame))
                else "tf"
            )
            extra = ", lidar upside down: scan angles mirrored" if flipped else ""
            return pose, flipped, f"{kind} transform {chain}{extra}"
    k = KACHAKA_LIDAR_MOUNT
    return (
        k,
        False,
        f"default Kachaka lidar mount ({k.x}, {k.y}, yaw {k.yaw}): no transform from "
        f"{' or '.join(BASE_FRAMES)} to scan frame {scan_frame!r} in the bag's tf",
    )


def _chain_keys(tree: TransformTree, target: str, source: str) -> list[tuple[str, str]]:
    chain = tree.path(target, source) or []
    keys = []
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        keys.append((a, b) if (a, b) in tree.static or (a, b) in tree.dynamic else (b, a))
    return keys


def body_yaw_rate(
    omega: np.ndarray, frame: str, tree: TransformTree
) -> tuple[np.ndarray, str | None]:
    """Yaw rate about the body z axis from gyro readings in the IMU's frame.

    omega: (N, 3) rad/s [w_x, w_y, w_z] in ``frame``. Returns ((N,) rad/s, note), the note
    saying why the IMU's own z axis was taken as the body's (None when it was not needed).
    """
    w_z = omega[:, 2]
    if not frame or frame in BASE_FRAMES:
        return w_z, None
    mat = next((m for b in BASE_FRAMES if (m := tree.lookup(b, frame)) is not None), None)
    if mat is None:
        return w_z, f"imu: no transform to frame {frame!r}; its z axis taken as the body's"
    if not np.allclose(mat[2, :3], (0.0, 0.0, 1.0)):
        return omega @ mat[2, :3], None  # body z component of the rotated rate vector
    return w_z, None
