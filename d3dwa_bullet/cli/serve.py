"""``d3dwa serve``: a simulated Kachaka behind the Kachaka API, for ``d3dwa drive`` (or any
Kachaka client) to drive without a robot (:mod:`d3dwa_bullet.live.sim_robot`).

Prints the address it listens on, then serves until Ctrl-C (or ``kill``), after which it
shuts down and exits 0 saying how many commands it took.
"""

from __future__ import annotations

import argparse
import errno
import signal
import socket
import threading

from d3dwa_bullet.cli.drive import robot_extra
from d3dwa_bullet.cli.options import (
    NOISE_HELP,
    add_world_option,
    load_cli_world,
    noise_arg,
    seed_arg,
)
from d3dwa_bullet.errors import ConfigError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="serve a simulated Kachaka over the Kachaka API (gRPC)")
    add_world_option(p, required=True, help="world name (see `d3dwa worlds`) or a world file")
    p.add_argument(
        "--noise", default="none", help=NOISE_HELP
    )  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="episode seed (noise draws)")
    p.add_argument("--port", type=int, default=26400, help="port to listen on (0: any free port)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0: all)")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--realtime", dest="mode", action="store_const", const="realtime",
        help="step physics with the wall clock at the control rate (default)",
    )  # fmt: skip
    mode.add_argument(
        "--lockstep", dest="mode", action="store_const", const="lockstep",
        help="advance one control period per velocity command (deterministic)",
    )  # fmt: skip
    p.set_defaults(func=cmd_serve, mode="realtime")


def cmd_serve(args: argparse.Namespace) -> int:
    # Input is checked before the robot extra and the simulator are imported.
    if not 0 <= args.port < 65536:
        raise ConfigError(f"--port must be 0-65535, got {args.port}")
    check_listen(args.host, args.port)
    world = load_cli_world(args.world, args.allow_empty)
    noise_arg(args.noise)
    seed_arg(args.seed)
    live = robot_extra("serve")
    # start-up cost: the simulator (pybullet) only when serving
    from d3dwa_bullet.evaluation.jobs import make_noise

    servicer = live.SimulatedKachaka(world, noise=make_noise(args.noise, args.seed), mode=args.mode)
    try:
        server, port = live.start_server(servicer, args.port, args.host)
    except BaseException:
        servicer.close()
        raise
    print(
        f"serving a simulated Kachaka on {args.host}:{port} (world {world.name}, noise "
        f"{args.noise}, seed {args.seed}, {args.mode}); Ctrl-C to stop",
        flush=True,
    )
    # Ctrl-C stops the server as the banner says, also where it started with SIGINT ignored (a
    # background job of a script): Python then installs no KeyboardInterrupt of its own.
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.default_int_handler) if main_thread else None
    try:
        server.wait_for_termination()
    except KeyboardInterrupt:
        pass
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    server.stop(grace=0.5).wait()
    servicer.close()
    last = servicer.requests[-1] if servicer.requests else None
    said = f"; the last asked for v {last[0]:g} m/s, w {last[1]:g} rad/s" if last else ""
    print(f"stopped after {len(servicer.received)} velocity commands{said}", flush=True)
    return 0


def check_listen(host: str, port: int) -> None:
    """ConfigError naming --host or --port unless a server could listen on host:port now
    (a probe socket bound as gRPC binds, with SO_REUSEADDR, then closed). gRPC would only
    say that it failed to bind, not which of the two is wrong."""
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        infos = socket.getaddrinfo(bare, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except (OSError, UnicodeError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise ConfigError(f"--host {host}: not an address to listen on ({reason})") from err
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as err:
            if err.errno in (errno.EADDRINUSE, errno.EACCES):
                raise ConfigError(
                    f"--port {port}: cannot listen on {host}:{port} ({err.strerror})"
                ) from err
            raise ConfigError(f"--host {host}: cannot listen there ({err.strerror})") from err
