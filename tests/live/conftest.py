"""A simulated Kachaka served in-process on a free port, for the live loop's tests.

Without the robot extra (kachaka-api, grpcio) nothing here can run: the directory's test
modules are not collected at all.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from d3dwa_bullet.world.model import World

try:
    from d3dwa_bullet.live import SimulatedKachaka, start_server
except ImportError:  # the robot extra is not installed
    collect_ignore_glob = ["test_*.py"]

Serve = Callable[..., tuple["SimulatedKachaka", str]]


@pytest.fixture
def serve() -> Iterator[Serve]:
    """serve(world, kind=SimulatedKachaka, **its options) -> (servicer, "127.0.0.1:PORT");
    every server started is stopped and its simulator closed after the test."""
    started = []

    def start(
        world: World, kind: type[SimulatedKachaka] | None = None, **options
    ) -> tuple[SimulatedKachaka, str]:
        servicer = (kind or SimulatedKachaka)(world, **options)
        server, port = start_server(servicer, 0)
        started.append((server, servicer))
        return servicer, f"127.0.0.1:{port}"

    yield start
    for server, servicer in started:
        server.stop(None).wait()
        servicer.close()
