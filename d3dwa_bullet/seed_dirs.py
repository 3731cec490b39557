"""Training-seed folders: ``<dir>/seed-<k>/``, seed lists like ``0-4``, and what a folder holds.

One trained method is a folder of training seeds (docs/design/learning-protocol.md#learning-protocol):
``d3dwa train --seeds 0-4 --out runs/NAME`` writes ``runs/NAME/seed-<k>/`` and ``--export``
ships them as ``policies/<method>/seed-<k>/``. Training, evaluation and the method registry
all name, list and parse those folders here.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from d3dwa_bullet.errors import ConfigError, ResultsError
from d3dwa_bullet.limits import MAX_SEED_VALUE, MAX_SEEDS
from d3dwa_bullet.loading import load_json

SEED_DIR = "seed-{}"
_SEED_NAME = re.compile(r"seed-(\d+)")


def seed_dir(folder: str | Path, seed: int) -> Path:
    """``folder/seed-<seed>``."""
    return Path(folder) / SEED_DIR.format(seed)


def seed_of(path: str | Path) -> int | None:
    """k for a folder named ``seed-<k>``, else None."""
    match = _SEED_NAME.fullmatch(Path(path).name)
    return int(match.group(1)) if match else None


def seed_dirs(folder: str | Path) -> dict[int, Path]:
    """The ``seed-<k>`` subfolders of folder by k, in increasing k ({} if none or no folder)."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    found = {seed_of(p): p for p in folder.iterdir() if p.is_dir() and seed_of(p) is not None}
    return {k: found[k] for k in sorted(found)}  # type: ignore[type-var]


def kept_evaluation(folder: str | Path, summary: Mapping[str, Any]) -> tuple[str, dict[str, Any]]:
    """(keep rule, validation record of the checkpoint it kept) of one training seed folder (a
    run's ``seed-<k>/`` or a shipped one): ``summary``'s (its summary.json) ``final_eval`` under
    ``keep: final`` in the folder's config.json, else its ``best_eval``; {} when it has none."""
    config = Path(folder) / "config.json"
    keep = load_json(config, ResultsError).get("keep", "best") if config.is_file() else "best"
    return keep, dict(summary.get("final_eval" if keep == "final" else "best_eval") or {})


def parse_seeds(text: str, option: str = "--seeds") -> list[int]:
    """'0-4' -> [0, 1, 2, 3, 4]; '0,3,7' -> [0, 3, 7]; ranges and lists mix ('0-2,5').

    ConfigError naming ``option`` and the bad part for anything else (negative, empty,
    reversed ranges, repeats), and for more than ``MAX_SEEDS`` seeds or a seed over
    ``MAX_SEED_VALUE`` (:mod:`d3dwa_bullet.limits`), counted before a range is expanded."""
    ranges: list[range] = []
    for part in text.split(","):
        part = part.strip()
        try:
            if "-" in part[1:]:
                lo, hi = (int(x) for x in part.split("-", 1))
                if hi < lo:
                    raise ValueError
                ranges.append(range(lo, hi + 1))
            else:
                ranges.append(range(int(part), int(part) + 1))
        except ValueError:
            raise ConfigError(
                f"{option}: {part!r} in {text!r} is not a seed or a range like 0-4"
            ) from None
    MAX_SEEDS.check(option, sum(len(r) for r in ranges), "seeds")
    MAX_SEED_VALUE.check(option, max(r[-1] for r in ranges))
    seeds = [s for r in ranges for s in r]
    if any(s < 0 for s in seeds):
        raise ConfigError(f"{option}: seeds must be >= 0, got {text!r}")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"{option}: {text!r} names a seed twice")
    return seeds
