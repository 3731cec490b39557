"""The entry of every tool in ``tools/``: the CLI's contract (README: any bad input is one
line naming what was wrong, exit status 2, never a traceback).

``ToolParser`` reports an argparse error as ``<tool>: error: <message>`` on one line (the
usage is what ``--help`` is for); ``tool_main`` wraps a tool's ``main(argv)`` so that a
project error (``D3DWAError``), an OSError a file system raised and a missing optional
extra end the same way, and Ctrl-C ends with status 130. A tool still prints its own
one-line errors where it knows the option to name.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn, Protocol

from d3dwa_bullet.cli.app import one_line, os_error_text
from d3dwa_bullet.cli.options import CommandParser
from d3dwa_bullet.cli.output import printable
from d3dwa_bullet.errors import D3DWAError

_running: list[str] = []
"""The tool whose main is running (``tool_main``): a parser names it, whatever sys.argv says."""

Main = Callable[[Any], int | None]
"""A tool's ``main(argv)``: argv a list or sequence of strings, or None for sys.argv."""


class ToolMain(Protocol):
    """``main`` wrapped by :func:`tool_main`: argv optional, an exit status back."""

    def __call__(self, argv: Sequence[str] | None = None) -> int: ...


class ToolParser(CommandParser):
    """An ArgumentParser whose errors are one line and exit status 2."""

    def error(self, message: str) -> NoReturn:
        fail(
            _running[-1] if _running else tool_name(self.prog),
            f"{message} (--help lists the options)",
        )


def tool_name(prog: str) -> str:
    """'value_check' of 'value_check.py', 'python -m tools.experiments.value_check' or a path."""
    last = prog.split()[-1] if prog.split() else prog
    return Path(last).stem.rpartition(".")[2] if last.endswith(".py") else last.rpartition(".")[2]


def fail(tool: str, message: str) -> NoReturn:
    """Print ``<tool>: error: <message>`` on one line and exit with status 2."""
    print(f"{tool}: error: {printable(one_line(message))}", file=sys.stderr)
    sys.exit(2)


def tool_main(main: Main) -> ToolMain:
    """``main`` under the one-line contract; the tool's name is its module's."""
    tool = main.__module__.rpartition(".")[2]
    if tool == "__main__":
        tool = Path(sys.argv[0]).stem

    @functools.wraps(main)
    def run(argv: Sequence[str] | None = None) -> int:
        _running.append(tool)
        try:
            return int(main(argv) or 0)
        except SystemExit as done:  # argparse's --help, or a tool's own exit
            code = done.code
            return code if isinstance(code, int) else (0 if code is None else 2)
        except D3DWAError as err:
            message = str(err)
        except ModuleNotFoundError as err:  # an optional extra (sb3, robot, ray) not installed
            message = f"needs the module {err.name!r}, which is not installed ({_extra(err)})"
        except OSError as err:
            message = os_error_text(err)
        except KeyboardInterrupt:
            print(f"{tool}: interrupted", file=sys.stderr)
            return 130
        finally:
            _running.pop()
        print(f"{tool}: error: {printable(one_line(message))}", file=sys.stderr)
        return 2

    return run


EXTRAS = {"stable_baselines3": "sb3", "onnxruntime": "robot", "kachaka_api": "robot", "ray": "ray"}
"""The pip extra that installs each optional module a tool may need."""


def _extra(err: ModuleNotFoundError) -> str:
    root = (err.name or "").partition(".")[0]
    extra = EXTRAS.get(root)
    return f"pip install -e '.[{extra}]'" if extra else "pip install it"
