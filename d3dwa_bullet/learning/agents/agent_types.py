"""The agents a checkpoint holds, as one type: a D3QN (torch) or a tabular DQDWA agent.

Its own module so that ``checkpoint_files`` (names and digests) stays free of torch."""

from __future__ import annotations

from d3dwa_bullet.learning.agents.d3qn import D3QNAgent
from d3dwa_bullet.learning.agents.dqdwa import DQDWAAgent

Agent = D3QNAgent | DQDWAAgent
