"""A follow-the-gap velocity planner, an external method of the d3dwa-bullet testbed."""

from follow_the_gap.planner import FollowTheGap

__all__ = ["FollowTheGap"]
__version__ = "0.1.0"
