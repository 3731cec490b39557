"""``--suite``: a world suite instead of ``--worlds`` on eval, sweep and worlds: BARN's 300
(``--split``, ``--world-ids``; docs/worlds.md#barn) or fresh BARN-style worlds (``--count``,
``--world-seed``; docs/worlds-barn-style.md, docs/design/barn-style.md), or both in one run
(``--suite barn,barn-style``: issue 79's BARN-style family is BARN's worlds and fresh ones
together; each row's layout group keeps the two apart)."""

from __future__ import annotations

import argparse
import re

from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.world.barn import SPLITS, barn_name, barn_selection
from d3dwa_bullet.world.barn_style import TRAINING_SEEDS, barn_style_names

SUITES = ("barn", "barn-style")
"""World suites ``--suite`` names: BARN's 300 worlds (docs/worlds.md#barn) and fresh BARN-style
worlds (docs/worlds-barn-style.md)."""


def add_suite_options(p: argparse.ArgumentParser) -> None:
    """``--suite``, ``--split``, ``--world-ids``, ``--count`` and ``--world-seed`` (see
    :func:`suite_world_names`)."""
    p.add_argument(
        "--suite",
        help="a world suite instead of --worlds: barn (BARN's 300 worlds), barn-style "
        "(fresh worlds from BARN's recipe; with --count), or both: barn,barn-style",
    )
    p.add_argument(
        "--split",
        help="with --suite barn: challenge (worlds 0, 6, ..., 294; the default of eval and sweep), "
        "train or all (the default of worlds)",
    )
    p.add_argument(
        "--world-ids",
        help="with --suite barn: a subset of the split, e.g. 0,6,12 or 0-30 (default: all)",
    )
    p.add_argument("--count", help="with --suite barn-style: how many worlds (a positive integer)")
    p.add_argument(
        "--world-seed",
        help=f"with --suite barn-style: the first world's seed, {TRAINING_SEEDS} (2^31, the "
        "default) or more; seeds below are training's",
    )


def _int_option(value: str) -> int | str:
    """``value`` as an int if it is one, else unchanged (the suite's check names it)."""
    return int(value) if re.fullmatch(r"[+-]?\d+", value.strip()) else value


def suite_list(text: str) -> list[str]:
    """``--suite``'s comma list: one or more of SUITES, each once (ConfigError naming it)."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise ConfigError(f"--suite is empty: name one of {', '.join(SUITES)}, or both")
    for name in names:
        if name not in SUITES:
            raise ConfigError(
                f"--suite: unknown suite {name!r}; choose from {', '.join(SUITES)} (or both: "
                f"{','.join(SUITES)})"
            )
    if len(set(names)) != len(names):
        raise ConfigError(f"--suite {text}: names a suite twice")
    return names


def suite_world_names(
    args: argparse.Namespace, default_split: str = "challenge"
) -> list[str] | None:
    """The world names of ``--suite`` (``BARN-0``, ..., then ``BARN-style-s<seed>``, ..., in
    the suites' given order), or None without ``--suite``; ``--split`` defaults to
    default_split. ConfigError for an unknown suite or split, a suite's option without it,
    --suite with --worlds, a bad subset (barn.barn_selection), and a --count or --world-seed
    BARN-style refuses (barn_style.barn_style_names: a count not a positive integer, a seed
    training uses)."""
    barn_only = (("--split", args.split), ("--world-ids", args.world_ids))
    style_only = (("--count", args.count), ("--world-seed", args.world_seed))
    if args.suite is None:
        for option, value in barn_only + style_only:
            if value is not None:
                raise ConfigError(
                    f"{option} needs --suite barn{'-style' if option in dict(style_only) else ''}"
                )
        return None
    suites = suite_list(args.suite)
    if args.worlds is not None:
        raise ConfigError("--worlds and --suite exclude each other: choose one")
    others = (style_only if "barn-style" not in suites else ()) + (
        barn_only if "barn" not in suites else ()
    )
    for option, value in others:
        if value is not None:
            raise ConfigError(f"{option} does not apply to --suite {args.suite}")
    names: list[str] = []
    for suite in suites:
        names += (
            _barn_style_names(args) if suite == "barn-style" else _barn_names(args, default_split)
        )
    return names


def _barn_style_names(args: argparse.Namespace) -> list[str]:
    if args.count is None:
        raise ConfigError("--suite barn-style needs --count (how many worlds)")
    seed = TRAINING_SEEDS if args.world_seed is None else _int_option(args.world_seed)
    return barn_style_names(_int_option(args.count), seed, "--count", "--world-seed")


def _barn_names(args: argparse.Namespace, default_split: str) -> list[str]:
    split = default_split if args.split is None else args.split
    if split not in SPLITS:
        raise ConfigError(f"--split: unknown split {split!r}; choose from {', '.join(SPLITS)}")
    return [barn_name(i) for i in barn_selection(split, args.world_ids)]
