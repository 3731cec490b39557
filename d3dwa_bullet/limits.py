"""Every bound on what a user can type or hand us, with the reason for it, in one place.

A value over its limit is refused before anything is allocated, expanded or started, with
one line that names the option (or file field), the limit and why::

    --seeds: 100000000000 seeds is over the limit of 10000 (one episode per seed ...)

The limits are far above anything the paper's protocol or a real robot needs; they exist so
that a typo (``--seeds 0-99999999999``, ``--time-limit 1e12``) or a hostile file ends in a
clear error instead of hours of work, a MemoryError or a machine that swaps. Raise one here,
with its reason, if a real use needs more.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from d3dwa_bullet.errors import ConfigError, D3DWAError


@dataclass(frozen=True)
class Limit:
    """An upper bound (inclusive) and the one-clause reason the message gives for it."""

    value: float
    why: str

    def check(
        self, option: str, value: float, unit: str = "", error: type[D3DWAError] = ConfigError
    ) -> None:
        """``error`` naming option, value, limit and reason unless ``value <= self.value``
        (a NaN is over every limit)."""
        if not value <= self.value:
            shown = f"{value:g}" if isinstance(value, float) else str(value)
            limit = f"{self.value:g}" if isinstance(self.value, float) else str(self.value)
            sep = " " if unit else ""
            raise error(
                f"{option}: {shown}{sep}{unit} is over the limit of {limit}{sep}{unit} ({self.why})"
            )


MAX_DOCUMENT_BYTES = Limit(4 * 2**20, "a YAML, JSON or XML file of this project is a few kB")
"""Size of one YAML, JSON or XML document read whole (a world, Gazebo SDF world, profile,
training config, map_server YAML, a ROS 2 bag's metadata.yaml, summary.json, config.json,
training_state.json). The largest the project writes is a few kB; 4 MiB leaves room for
generated worlds with thousands of obstacles and refuses a huge or endless file before a
byte of it is read. A results directory's meta.json has its own limit, below."""

MAX_RUN_META_BYTES = Limit(
    256 * 2**20, "a run's meta.json lists every episode's key, one line each"
)
"""Size of a results directory's meta.json, read whole. It lists the key of every job of the
run, about 50 bytes each, so it grows with the run as results.csv does: the BARN yardstick's
137,700 episodes take about 7 MB. 256 MiB holds about five million episodes."""

MAX_TEXT_BYTES = Limit(1 * 2**30, "text files are read whole into memory")
"""Size of any other text file read whole (results.csv, metrics.jsonl): a sweep of a million
episodes writes a few hundred MB; 1 GiB is past any run this project makes."""

MAX_NESTING_DEPTH = Limit(32, "no file of this project nests deeper than 4 levels")
"""Nesting of mappings and lists in a YAML or JSON document. The deepest file the project
reads (a training config's ``agent:`` block, a world's obstacle list) nests 4 levels; a
document nested thousands of levels deep would otherwise end in a RecursionError."""

MAX_XML_DEPTH = Limit(64, "an SDF world nests about 8 elements deep, a nested model 3 more")
"""Nesting of elements in an XML document (a Gazebo SDF world): sdf > world > model > link >
collision > geometry > box > size is 8 levels, and each nested ``<model>`` adds a few; a world
of thousands of nested models would otherwise end in a RecursionError."""

MAX_ALIAS_NODES = Limit(10_000, "each YAML alias repeats its anchor's whole node")
"""Nodes that YAML aliases (``*name``) may add to a document, each alias counted as the full
size of the node it repeats. ``yaml.safe_dump`` writes an alias for a list used twice, so a
few are ordinary; nine lines of nested aliases (the "billion laughs") would add 9^9.
"""

MAX_SEEDS = Limit(10_000, "one episode or training run per seed")
"""Seeds in one ``--seeds`` / ``--policy-seeds`` list or count (``0-4``, ``0,3,7``, or
``eval --seeds N``). Checked before a range is expanded, so ``0-99999999999`` never builds a
list. The paper's tables use 5 training seeds and tens of evaluation seeds."""

MAX_SEED_VALUE = Limit(2**32 - 1, "numpy and PyBullet seeds are 32-bit")
"""Largest seed value a seed list or range may name."""

MAX_LAYOUTS = Limit(1_000, "each layout is a fresh world built per episode")
"""``sweep --layouts``: generated layouts per style (the protocol uses 10)."""

MAX_LEVELS = Limit(100, "each level multiplies the sweep's episodes")
"""``sweep --levels``: non-zero noise levels per axis (the protocol uses 4)."""

MAX_EPISODES = Limit(1_000_000, "about a CPU-year of episodes")
"""Episodes of one ``eval`` or ``sweep`` (worlds x methods x training seeds x conditions x
seeds), counted before the job list is built."""

MAX_PROCESSES_PER_CORE = 4
"""Worker processes (``--workers``, ``--n-envs`` / ``n_envs``) per core of this machine:
each is a simulator in its own process; past a few per core they only add memory and
context switches."""

MAX_TIME_LIMIT_S = Limit(3600.0, "an episode is a minute of simulated time; an hour is ample")
"""Episode time limit, seconds of simulated time (``--time-limit`` and a world's
``time_limit``); the paper's episodes last 60 s."""

MAX_STEM_BYTES = Limit(
    160, "a file name has at most 255 bytes, some taken by its suffix and a temporary name"
)
"""Bytes (UTF-8) of the part of a file name made from a name the user gave: a world's
``name:`` in ``figures/<world>_time.png``, an episode's key in ``logs/``. A longer name is
cut and ends in a hash of the whole (:func:`d3dwa_bullet.io.file_stem`), so it stays unique;
the atomic writer's temporary name adds 14 bytes to the final one."""

MAX_DECISION_STEPS = Limit(100, "a decision period of 10 s at 10 Hz is a sixth of an episode")
"""Longest decision period, control steps each chosen action is held (docs/design/agent.md#decision-period):
a training config's and the env's ``decision_steps``, and what a policy's meta.json or ONNX
metadata may record, and a reference method's hold (``random@10``). The paper decides every
step; the shipped policies every 10."""


def is_decision_period(value: object) -> bool:
    """Whether ``value`` is a decision period: a whole number in [1, MAX_DECISION_STEPS]."""
    return (
        isinstance(value, int)
        and not isinstance(value, bool)
        and 1 <= value <= MAX_DECISION_STEPS.value
    )


MAX_NOTE_VALUE_CHARS = Limit(120, "a note is one line of a page, a table and meta.json")
"""Characters of one value a note copies from a file the user brought (a field of a policy's
config.json named on the page, in table.md and meta.json); a longer value is cut and says so."""

MAX_NOTE_CHARS = Limit(2_000, "a note is one line of a page, a table and meta.json")
"""Characters of one whole note (several values and a reason); longer is cut and says so."""


def cut_text(text: str, limit: Limit) -> str:
    """``text``, or its first ``limit`` characters and a mark saying how long it was."""
    size = int(limit.value)
    if len(text) <= size:
        return text
    return f"{text[:size]}... [cut: {len(text)} characters]"


MAX_PHYSICS_HZ = Limit(10_000, "each control step runs physics_hz / control_hz PyBullet steps")
"""``--physics-hz`` of run, eval and sweep: the protocol simulates at 240 Hz; 10 kHz makes
every simulated second 10,000 PyBullet steps."""

MAX_CONTROL_HZ = Limit(1_000, "the planner runs once per control step; the protocol uses 10 Hz")
"""``--control-hz`` of run, eval and sweep: a 60 s episode at 1 kHz is already 60,000
planner calls."""

MAX_TOTAL_STEPS = Limit(100_000_000, "400 times the protocol's 250,000 steps: days of training")
"""Environment steps of one training (``--total-steps`` and a config's ``total_steps``),
checked when a run starts: a typo (``--total-steps 1e12``) would otherwise train until
someone stops it."""

MAX_MAP_PIXELS = Limit(50_000_000, "a map_server image is decoded whole into memory")
"""Pixels of a map_server image, read from its PNG/PGM header before it is decoded: 50
megapixels is a 7 km square at 1 m/px, or a 350 m square at the usual 5 cm/px. Other
image formats are left to OpenCV's own bound (2^30 pixels)."""

MAX_MAP_BOXES = Limit(200_000, "each box is a PyBullet body")
"""Boxes a map_server image may become after merging runs of occupied pixels."""

MAX_REPLAY_CAPACITY = Limit(50_000_000, "the replay buffer is allocated whole")
"""Replay capacity in transitions (``agent.buffer_size``); the paper's agent keeps 100k."""

MAX_POLICY_BYTES = Limit(64 * 2**20, "an exported policy network is a few hundred kB")
"""Size of an ONNX policy file (``--onnx FILE``), read whole before onnxruntime parses it:
the shipped networks export to 90-130 kB; 64 MiB leaves room for networks a thousand
times larger."""

MAX_ONNX_NODES = Limit(1_000, "an exported policy has two nodes per layer and five more")
"""Operators in an ONNX policy's graph: the shipped networks have 9 (two hidden layers)."""

MAX_ONNX_ELEMENTS = Limit(2**24, "one inference holds every weight and intermediate in memory")
"""Float values one inference of one observation holds, weights and every intermediate
tensor counted (64 MiB of float32): the shipped networks hold 20-40 thousand. A graph of
allowed operators can still broadcast two small weight vectors into a terabyte tensor; this
refuses it before it runs (``learning/agents/onnx_graph.py``)."""

MAX_ONNX_MACS = Limit(2**25, "a decision must fit well inside one 0.1 s control period")
"""Multiply-adds of one inference of one observation (Gemm's M x K x N plus one per element
of every other operator's output): about 20-40 ms on one core at the bound, against 20-40
thousand (0.02-0.04 ms) for the shipped networks. A slower decision would be the
watchdog's to stop (``d3dwa drive --watchdog``)."""

REPLAY_MEMORY_FRACTION = 0.5
"""A replay buffer may take at most this fraction of the memory available when it is
allocated (or when the training config is read), so training never pushes the machine into
swap."""


def max_processes() -> int:
    """Most worker processes a command may start on this machine."""
    return MAX_PROCESSES_PER_CORE * (os.cpu_count() or 1)


def check_processes(option: str, count: int) -> None:
    """ConfigError unless ``count`` worker processes fit :func:`max_processes`."""
    Limit(max_processes(), f"{MAX_PROCESSES_PER_CORE} per core of this machine").check(
        option, count, "processes"
    )


def available_memory() -> int:
    """Bytes of memory available to a new allocation (``MemAvailable`` on Linux; free
    physical pages elsewhere; a very large number when neither can be read)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return 2**62


def check_weights(
    option: str, weights: list[float] | tuple[float, ...], error: type[D3DWAError] = ConfigError
) -> None:
    """``error`` unless every weight is a finite number >= 0 and their sum is finite and
    > 0 (``[1e308, 1e308]`` overflows to inf: probabilities would come out NaN)."""
    if not all(
        isinstance(w, int | float) and not isinstance(w, bool) and math.isfinite(w) and w >= 0
        for w in weights
    ):
        raise error(f"{option}: weights must be finite numbers >= 0, got {list(weights)}")
    total = sum(float(w) for w in weights)  # not fsum: it raises on overflow
    if not (math.isfinite(total) and total > 0):
        raise error(
            f"{option}: weights must have a finite sum > 0, got {list(weights)} (sum {total:g})"
        )
