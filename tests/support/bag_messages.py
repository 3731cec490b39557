"""Raw message builders shared by the bag tests.

``BagRecorder.write_scan`` also writes the recorder's tf_static and frames; these build a
bare message, for bags with only some topics, odd scan geometry or corrupt data.
"""

from __future__ import annotations

import numpy as np

from transfer.bag_writer import BagRecorder
from transfer.topics import LASER_SCAN


def scan_msg(
    rec: BagRecorder,
    stamp_ns: int,
    ranges,
    frame: str = "lidar_link",
    angle_min: float = -1.0,
    inc: float = 0.1,
):
    """A sensor_msgs/LaserScan of float32 ranges (any count, zero included), range 0.05-10 m."""
    ranges = np.asarray(ranges, dtype=np.float32)
    return rec.message(
        LASER_SCAN,
        header=rec.header(stamp_ns, frame),
        angle_min=angle_min,
        angle_max=angle_min + inc * max(ranges.size - 1, 0),
        angle_increment=inc,
        time_increment=0.0,
        scan_time=0.0,
        range_min=0.05,
        range_max=10.0,
        ranges=ranges,
        intensities=np.zeros(0, dtype=np.float32),
    )
