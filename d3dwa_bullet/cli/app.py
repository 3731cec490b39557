"""The ``d3dwa`` command line.

    d3dwa worlds                          list the shipped worlds
    d3dwa methods                         list the methods, built-in and installed from outside
    d3dwa run --world TS1 --method dwa3   one episode (headless; --gui to watch)
    d3dwa eval --out results/             methods x worlds x seeds -> results.csv, table.md, figures
    d3dwa sweep --methods dwa1 --out DIR  methods x noise levels on R1-R3 + unseen layouts -> plots
    d3dwa report DIR                      a results directory -> DIR/report.md
    d3dwa compare DIR --methods A,B       P(A improves on B) over training seeds, with intervals
    d3dwa train --config configs/d3dwa.yaml --out runs/d3dwa   train a learned method (--resume)
    d3dwa replay / record / compare-scans ROS bags (see d3dwa_bullet.cli.transfer)
    d3dwa calibrate BAG... --out my_robot.yaml   fit a noise profile to your own bags
    d3dwa export --onnx DIR               trained D3QN policies -> ONNX files (run --onnx FILE)
    d3dwa serve --world R1 --lockstep     a simulated Kachaka behind the Kachaka API (gRPC)
    d3dwa drive --kachaka HOST --goal X,Y --method dwa3   drive a robot through that API

Each command is one module of this package (``worlds``, ``methods``, ``run``, ``eval``, ``sweep``,
``report``, ``compare``, ``train``, ``bags``, ``calibrate``, ``export``, ``drive``, ``serve``)
with ``add_parser(sub)`` and its ``cmd_*(args)``; shared
options are in ``options``. A command imports the simulator, torch or matplotlib only when
it runs, so ``d3dwa --help`` and ``d3dwa worlds`` start quickly.

Every failure the user can cause (unknown name, malformed file, bad checkpoint) ends with a
one-line ``d3dwa: error: ...`` on stderr and exit status 2, not a traceback; so does a file
system that refuses a write (a full disk, the file-size limit, a read-only directory, a file
where a directory should be): the line names the path and the system's reason. The line's
control characters (a robot's error text may carry ESC or BEL) are printed as escapes
(:func:`d3dwa_bullet.cli.output.printable`). Ctrl-C (or
``kill``) ends with one ``d3dwa: interrupted`` line and status 130; the line says what was
kept only where something was (a command's ``interrupted`` default, or the message of the
KeyboardInterrupt a command re-raises, as ``record`` does with the bag's message count).
"""

from __future__ import annotations

import argparse
import os
import select
import shlex
import signal
import sys
import threading
from collections.abc import Sequence

import d3dwa_bullet.cli.bags as bags_commands
import d3dwa_bullet.cli.calibrate as calibrate_command
import d3dwa_bullet.cli.compare as compare_command
import d3dwa_bullet.cli.drive as drive_command
import d3dwa_bullet.cli.eval as eval_command
import d3dwa_bullet.cli.export as export_command
import d3dwa_bullet.cli.methods as methods_command
import d3dwa_bullet.cli.report as report_command
import d3dwa_bullet.cli.run as run_command
import d3dwa_bullet.cli.serve as serve_command
import d3dwa_bullet.cli.sweep as sweep_command
import d3dwa_bullet.cli.train as train_command
import d3dwa_bullet.cli.worlds as worlds_command
from d3dwa_bullet.cli.options import CommandParser
from d3dwa_bullet.cli.output import printable
from d3dwa_bullet.errors import D3DWAError

COMMANDS = (
    worlds_command,
    methods_command,
    run_command,
    eval_command,
    sweep_command,
    report_command,
    compare_command,
    train_command,
    bags_commands,
    calibrate_command,
    export_command,
    drive_command,
    serve_command,
)
"""Modules with ``add_parser(sub)``, in the order of ``d3dwa --help``."""


def build_parser() -> argparse.ArgumentParser:
    ap = CommandParser(prog="d3dwa", description="D3DWA testbed: Kachaka + DWA + D3QN in PyBullet")
    sub = ap.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    args.command_line = shlex.join(["d3dwa", *(sys.argv[1:] if argv is None else argv)])
    previous = signal.getsignal(signal.SIGTERM)
    if threading.current_thread() is threading.main_thread():
        # `kill PID` stops like Ctrl-C: finished rows are kept, local workers terminated.
        signal.signal(signal.SIGTERM, _sigterm)
    try:
        return int(args.func(args) or 0)
    except D3DWAError as err:
        print(f"d3dwa: error: {printable(one_line(str(err)))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:
        kept = str(err) or getattr(args, "interrupted", "")
        kept = printable(one_line(kept))
        print("d3dwa: interrupted" + (f"; {kept}" if kept else ""), file=sys.stderr)
        return 130
    except BrokenPipeError:
        if not _stdout_gone():
            raise
        return 141  # as a shell reports a command ended by SIGPIPE
    except OSError as err:  # a file system refused what no writer of ours named (WriteError)
        print(f"d3dwa: error: {printable(one_line(os_error_text(err)))}", file=sys.stderr)
        return 2
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)


def one_line(message: str) -> str:
    """A message on one line: its non-blank lines joined by '; ' (most are one line already)."""
    return "; ".join(line.strip() for line in message.splitlines() if line.strip())


def os_error_text(err: OSError) -> str:
    """An OSError as '<path>: <reason>' (``No space left on device``), without errno."""
    paths = [str(p) for p in (err.filename, err.filename2) if p is not None]
    reason = err.strerror or str(err)
    return f"{' -> '.join(paths)}: {reason}" if paths else reason


def _stdout_gone() -> bool:
    """True if stdout's reader went away (``d3dwa run ... | head -1``): the command then stops
    quietly, as Unix tools do, and stdout is pointed at /dev/null so the interpreter's last
    flush cannot fail again. False when stdout still has a reader (the broken pipe was
    another), or is no file."""
    try:
        fd = sys.stdout.fileno()
    except (OSError, ValueError):
        return False
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    if not any(events & select.POLLERR for _, events in poller.poll(0)):
        return False
    os.dup2(os.open(os.devnull, os.O_WRONLY), fd)
    return True


def _sigterm(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
