"""Where episodes run: this process, a pool of local processes, or a Ray cluster.

Every backend runs the same picklable function on the same jobs and yields
``(job, result)`` pairs as they finish, in completion order. An episode depends only on
its job (world, method, seed, noise), never on the process that ran it, so the results
are identical whatever the backend; only the order of the rows differs.

``--ray ADDRESS`` takes:

``local``
    start a private Ray instance in this process with ``--workers`` CPUs, stopped at the end;
``auto``
    connect to the cluster that ``ray start`` runs on this machine (or ``RAY_ADDRESS``);
``HOST:PORT`` or ``ray://HOST:PORT``
    connect to that cluster's GCS (the port ``ray start --head --port`` printed) or its
    Ray Client server. A cluster with token authentication (the default of recent
    ``ray start``) needs ``RAY_AUTH_MODE=token`` and its token, as Ray documents; for a
    loopback address this machine's ``~/.ray/auth_token`` is used, as Ray does for ``auto``.

Before ``ray.init`` connects to an address, a gRPC handshake with it must succeed within
``RAY_CONNECT_TIMEOUT_S``: ``ray.init`` itself retries a silent address for minutes.
Every node of a remote cluster needs the same version of this package installed (and the
``policies/`` of the learned methods at the same place); a local Ray instance shares this
machine's installation.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from multiprocessing import get_context
from pathlib import Path
from typing import Any, TypeVar

import cv2

from d3dwa_bullet.errors import BackendError, D3DWAError
from d3dwa_bullet.sim.lidar_params import set_ray_threads

RAY_CONNECT_TIMEOUT_S = 5.0
"""How long a Ray address may take to answer a gRPC handshake, s."""
RAY_CLIENT_PORT = 10001
"""Ray Client's default port, for ``ray://HOST`` without a port."""
RAY_TOKEN_PATH = Path.home() / ".ray" / "auth_token"
"""Where ``ray start`` keeps the cluster's token when token authentication is on."""

J = TypeVar("J")
R = TypeVar("R")
JobFn = Callable[[J, Any], tuple[J, R]]


def default_workers() -> int:
    """All cores of this machine."""
    return os.cpu_count() or 1


def one_core_per_worker() -> None:
    """In a worker that shares the machine with others, keep OpenCV's distance transform
    (the planner's) and the lidar's ray batch (``sim.lidar_params.set_ray_threads``) on one
    thread each: one process per core already fills the cores, and a single process (training,
    one episode) keeps their default of every core."""
    cv2.setNumThreads(1)
    set_ray_threads(1)


def _init_pool_worker() -> None:
    """Pool workers leave Ctrl-C to the parent, which terminates them (no tracebacks)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    one_core_per_worker()


def _call(args: tuple[JobFn, Any, Any]) -> tuple[Any, Any]:
    fn, job, config = args
    return fn(job, config)


def run_local(fn: JobFn, jobs: Sequence[J], config: Any, workers: int) -> Iterator[tuple[J, R]]:
    """In this process (workers <= 1, or a single job), else a pool of spawned processes.

    Spawned, not forked: a forked child would inherit PyBullet and torch state. When the
    caller stops early (an error, Ctrl-C, SIGTERM via the CLI) the pool is terminated, so
    no worker goes on running episodes nobody will record.
    """
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield fn(job, config)
        return
    pool = get_context("spawn").Pool(
        processes=min(workers, len(jobs)), initializer=_init_pool_worker
    )
    try:
        # chunksize 1: episodes last seconds to a minute, so balance beats batching.
        yield from pool.imap_unordered(_call, [(fn, job, config) for job in jobs], chunksize=1)
        pool.close()
    finally:
        pool.terminate()
        pool.join()


def _import_ray():
    try:  # optional dependency: the ray extra
        import ray
    except ImportError as err:
        raise BackendError(
            "--ray needs Ray: pip install 'd3dwa-bullet[ray]' (or pip install 'ray>=2.30')"
        ) from err
    return ray


def split_address(address: str) -> tuple[str, int, bool]:
    """'ray://h:p' / 'h:p' -> (host, port, is_ray_client). BackendError if malformed."""
    text = address.strip()
    client = text.startswith("ray://")
    rest = text[len("ray://") :] if client else text
    host, sep, port = rest.rpartition(":")
    if not sep:
        host, port = rest, str(RAY_CLIENT_PORT) if client else ""
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise BackendError(
            f"Ray address {address!r} is not 'local', 'auto', HOST:PORT or ray://HOST:PORT"
        )
    return host.strip("[]"), int(port), client


def check_address(address: str | None) -> None:
    """BackendError unless address is None, 'local', 'auto' or a well-formed HOST:PORT."""
    if address is not None and address not in ("local", "auto"):
        split_address(address)


def probe_address(address: str, timeout: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """Raise BackendError unless a gRPC server (a Ray GCS or Ray Client) answers at address.

    A plain TCP connect is not enough: an open port of another service would pass it and
    leave ``ray.init`` waiting for minutes.
    """
    host, port, _ = split_address(address)
    try:  # refused or unreachable: known at once, or after the timeout
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as err:
        raise BackendError(
            f"Ray address {address!r} does not answer ({err.strerror or err}); is the cluster "
            "running (`ray start --head --port PORT`) and the port reachable?"
        ) from err
    try:  # optional dependency: the ray extra declares grpcio
        import grpc
    except ImportError:  # without it, the TCP check above stands alone
        return
    target = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
    channel = grpc.insecure_channel(target)
    try:
        grpc.channel_ready_future(channel).result(timeout=timeout)
    except grpc.FutureTimeoutError as err:
        raise BackendError(
            f"Ray address {address!r} does not answer as a Ray cluster within {timeout:g} s "
            "(the port is open, but no gRPC server behind it)"
        ) from err
    finally:
        channel.close()


def connect_ray(address: str, workers: int) -> bool:
    """ray.init for address; returns True if this call started the Ray session (and so must
    shut it down). An already initialised session (e.g. by the caller) is reused."""
    ray = _import_ray()
    if ray.is_initialized():
        return False
    quiet: dict[str, Any] = {"log_to_driver": False, "logging_level": logging.ERROR}
    try:
        if address == "local":
            ray.init(address="local", num_cpus=max(1, workers), include_dashboard=False, **quiet)
        elif address == "auto":
            ray.init(address="auto", **quiet)
        else:
            probe_address(address)
            if is_loopback(address):
                _use_local_token()
            ray.init(address=address, **quiet)
    except BackendError:
        raise
    except (ConnectionError, RuntimeError, TimeoutError, ValueError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        hint = ""
        if address not in ("local", "auto") and os.environ.get("RAY_AUTH_MODE") != "token":
            hint = (
                "; if the cluster uses token authentication (the default of `ray start`), "
                "set RAY_AUTH_MODE=token and RAY_AUTH_TOKEN (or ~/.ray/auth_token)"
            )
        raise BackendError(f"cannot connect to Ray at {address!r}: {first}{hint}") from err
    return True


def is_loopback(address: str) -> bool:
    """True for a Ray address on this machine (127.x.x.x, ::1, localhost)."""
    host = split_address(address)[0]
    return host == "localhost" or host == "::1" or host.startswith("127.")


def _use_local_token() -> None:
    """Token auth with this machine's token, for a cluster on this machine.

    Ray does this itself for ``auto`` but never for an explicit address (a token must not
    be sent to an arbitrary host); a loopback address is this machine, like ``auto``.
    """
    if "RAY_AUTH_MODE" in os.environ or not RAY_TOKEN_PATH.exists():
        return
    try:  # optional dependency (the ray extra); a private module, absent from older Rays
        from ray._private.authentication.authentication_token_setup import (
            maybe_enable_token_auth_if_token_available,
        )
    except ImportError:  # a Ray without token auth: nothing to do
        return
    maybe_enable_token_auth_if_token_available(warn_if_disabled=False)


@contextmanager
def ray_session(address: str, workers: int) -> Iterator[Any]:
    """The ray module, connected to address for the duration of the block."""
    started = connect_ray(address, workers)
    ray = _import_ray()
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def _ray_call(fn: JobFn, job: Any, config: Any) -> tuple[Any, Any]:
    """A Ray task: one CPU each, like a pool worker."""
    one_core_per_worker()
    return fn(job, config)


def run_ray(ray: Any, fn: JobFn, jobs: Sequence[J], config: Any) -> Iterator[tuple[J, R]]:
    """One Ray task per job (1 CPU each) on a connected session, yielded as they finish."""
    remote = ray.remote(num_cpus=1)(_ray_call)
    config_ref = ray.put(config)
    pending = [remote.remote(fn, job, config_ref) for job in jobs]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayTaskError as err:
                    # Our own errors (a missing policy on a node, ...) keep their one line.
                    if isinstance(getattr(err, "cause", None), D3DWAError):
                        raise err.cause from None
                    raise
    finally:
        for ref in pending:  # interrupted: cancel what has not finished
            ray.cancel(ref, force=True)


@contextmanager
def open_backend(
    workers: int, ray_address: str | None = None, needed: bool = True
) -> Iterator[Callable[[JobFn, Sequence[J], Any], Iterator[tuple[J, R]]]]:
    """A runner ``run(fn, jobs, config)`` for the chosen backend.

    With ray_address, Ray is connected on entry (so a bad address fails before any work)
    unless needed is False (nothing to run), and shut down on exit if it was started here.
    """
    check_address(ray_address)  # a malformed address is an error even with nothing to run
    if ray_address is None or not needed:
        yield lambda fn, jobs, config: run_local(fn, jobs, config, workers)
        return
    with ray_session(ray_address, workers) as ray:
        yield lambda fn, jobs, config: run_ray(ray, fn, jobs, config)
