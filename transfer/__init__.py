"""Sim-to-real transfer through ROS bags.

``bag_reader`` turns a ROS 1 / ROS 2 bag into numpy time series, ``replay`` runs every
recorded scan through a step function (observations only by default), ``bag_writer``
records ROS 2 or ROS 1 bags with the Kachaka topic names, and ``compare`` sets two bags'
scans side by side, sector by sector.

``transfer.sim_bridge`` (the simulator's decision pipeline as a replay step, and simulated
episodes recorded as bags) is deliberately not imported here: ``import transfer`` stays
free of pybullet, so bag code runs where the simulator is not installed.
"""

from transfer.bag_reader import BagData, read_bag
from transfer.bag_writer import BagRecorder, quantize_scan
from transfer.compare import compare_scans, format_scan_comparison
from transfer.replay import replay_bag
from transfer.replay_output import ReplayResult
from transfer.replay_step import ScanStep, SkipScan, StepOutput, observe_only
from transfer.topics import TopicMap, TopicResolution, resolve_topics

__all__ = [
    "BagData",
    "BagRecorder",
    "ReplayResult",
    "ScanStep",
    "SkipScan",
    "StepOutput",
    "TopicMap",
    "TopicResolution",
    "compare_scans",
    "format_scan_comparison",
    "observe_only",
    "quantize_scan",
    "read_bag",
    "replay_bag",
    "resolve_topics",
]
