"""``d3dwa serve`` refusing where it cannot listen: exit 2 and one stderr line, ours (gRPC's
C core logs lines of its own to stderr unless kept quiet), before the simulator is imported."""

from __future__ import annotations

import socket
import subprocess
import sys
from collections.abc import Iterator

import pytest

pytest.importorskip("kachaka_api", reason="the robot extra is not installed")

from d3dwa_bullet.live.sim_robot import host_port  # noqa: E402
from tests.support.serve_process import D3DWA  # noqa: E402


@pytest.fixture
def busy_port() -> Iterator[int]:
    """A port another program listens on."""
    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        yield other.getsockname()[1]


def stderr_of(*argv: str) -> tuple[int, list[str]]:
    done = subprocess.run(
        [*D3DWA, "serve", "--world", "R1", *argv], capture_output=True, text=True, timeout=60
    )
    return done.returncode, done.stderr.splitlines()


@pytest.mark.parametrize(
    ("host", "said"),
    [
        ("nosuch.invalid", "--host nosuch.invalid: not an address to listen on"),
        ("256.1.1.1", "--host 256.1.1.1: not an address to listen on"),
        ("192.0.2.1", "--host 192.0.2.1: cannot listen there"),  # TEST-NET: not this machine's
    ],
)
def test_a_bad_host_is_one_line_naming_it(host, said):
    code, lines = stderr_of("--host", host, "--port", "0")
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"d3dwa: error: {said}"), lines


def test_a_busy_port_is_one_line_naming_it(busy_port):
    code, lines = stderr_of("--port", str(busy_port))
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"d3dwa: error: --port {busy_port}: cannot listen"), lines
    assert "in use" in lines[0]


def test_grpc_logs_nothing_of_its_own_when_it_cannot_bind(busy_port):
    """Where only gRPC finds out (the port taken between serve's check and the bind), its
    failure is still our one line: the C core logs nothing to stderr."""
    script = (
        "import sys\n"
        "from d3dwa_bullet.cli.drive import robot_extra\n"
        "from d3dwa_bullet.errors import ConfigError\n"
        "from d3dwa_bullet.world.registry import load_world\n"
        "live = robot_extra('serve')\n"
        "servicer = live.SimulatedKachaka(load_world('R1'))\n"
        "try:\n"
        f"    live.start_server(servicer, {busy_port})\n"
        "except ConfigError as err:\n"
        "    print('d3dwa: error:', err, file=sys.stderr)\n"
        "servicer.close()\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    lines = done.stderr.splitlines()
    assert done.returncode == 0 and len(lines) == 1, lines
    assert lines[0].startswith(f"d3dwa: error: --port {busy_port}: cannot listen"), lines


@pytest.mark.parametrize(
    ("host", "port", "address"),
    [("::1", 5, "[::1]:5"), ("[::1]", 5, "[::1]:5"), ("127.0.0.1", 5, "127.0.0.1:5"),
     ("localhost", 5, "localhost:5")],
)  # fmt: skip
def test_an_ipv6_host_is_bracketed_for_grpc_with_or_without_brackets(host, port, address):
    assert host_port(host, port) == address
