"""``d3dwa run``: one episode of one method on one world (headless; ``--gui`` to watch).

``--plot PNG`` is checked before the episode starts (a file name, in a directory that can be
written, of a type matplotlib writes), and the episode's summary (text or ``--json``) is
printed before the figure is drawn, so a figure that still cannot be written never costs
the result.
"""

from __future__ import annotations

import argparse

from d3dwa_bullet.cli.options import (
    add_episode_options,
    add_task_options,
    add_world_option,
    episode_config,
    load_task_world,
    noise_arg,
    seed_arg,
)
from d3dwa_bullet.cli.output import check_out_file, json_text
from d3dwa_bullet.errors import ConfigError
from d3dwa_bullet.method_specs import METHODS
from d3dwa_bullet.sim.backend import check_backend_worlds


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run one episode")
    add_world_option(p, required=True, help="world name (see `d3dwa worlds`) or a world file")
    p.add_argument(
        "--method",
        required=True,
        help=f"one of {', '.join(METHODS)}, or one from outside the package: package.module:Name, "
        "an installed entry point (d3dwa methods) or an ONNX file from d3dwa export",
    )
    p.add_argument("--seed", type=int, default=0)
    add_task_options(p)
    p.add_argument("--gui", action="store_true", help="open the PyBullet GUI")
    p.add_argument("--plot", help="write the trajectory over the map to this PNG")
    p.add_argument(
        "--colour-by", choices=("time", "tau"), default="time", help="trajectory colour in --plot"
    )
    add_episode_options(p)
    p.add_argument(
        "--onnx",
        metavar="FILE",
        help="an ONNX policy exported by `d3dwa export --onnx` for a learned method, run by "
        "onnxruntime (instead of --policy: checks the export drives the same episode)",
    )
    p.set_defaults(func=cmd_run, interrupted="the episode was not finished; nothing written")


def cmd_run(args: argparse.Namespace) -> int:
    # Input is checked before the simulator is imported, so a refusal comes at once.
    config = episode_config(args)
    world = load_task_world(args)
    check_backend_worlds(config.backend, [world])
    noise_arg(args.noise)
    seed_arg(args.seed)
    if args.onnx is not None and args.policy is not None:
        raise ConfigError(
            f"--onnx {args.onnx} and --policy {args.policy} both name the policy: give one"
        )
    if args.plot:
        check_out_file(args.plot, "--plot", figure_suffixes())
    # start-up cost: the simulator (pybullet) is imported only when an episode runs
    from d3dwa_bullet.controllers import make_controller
    from d3dwa_bullet.episode import run_episode
    from d3dwa_bullet.evaluation.jobs import make_noise
    from d3dwa_bullet.method_specs import method_label

    controller = make_controller(args.method, args.policy, onnx=args.onnx)
    result = run_episode(
        world, controller, seed=args.seed, noise=make_noise(args.noise, args.seed),
        noise_name=args.noise, config=config, gui=args.gui,
    )  # fmt: skip
    summary = result.summary()
    if args.json:
        print(json_text(summary), flush=True)
    else:
        print(
            f"{summary['world']} {summary['method']} seed {summary['seed']}: {summary['outcome']} "
            f"in {summary['time_s']:.1f} s, TL {summary['tl_m']:.2f} m, PD {summary['pd_rad']:.2f} rad, "
            f"min clearance {summary['min_clearance_m']:.3f} m ({summary['steps']} steps)",
            flush=True,
        )
        if controller.origin:
            overran = f"; {result.overruns} call(s) over the control period" * bool(result.overruns)
            print(f"method: {controller.source}{overran}", flush=True)
        elif controller.policy is not None or controller.hold > 1:
            print(f"policy: {controller.source}", flush=True)
    if args.plot:
        # start-up cost: matplotlib (~0.3 s) only with --plot
        from d3dwa_bullet.evaluation.plotting import trajectory_figure
        from d3dwa_bullet.planning.global_plan import logged_paths

        log = result.log
        t = list(log["t"]) + [result.time_s]
        tau = list(log["tau"]) + list(log["tau"][-1:])
        run = {
            "label": method_label(args.method), "method": args.method,
            "outcome": result.outcome, "t": t, "x": log["true_x"], "y": log["true_y"], "tau": tau,
            "recovery": log["recovery"], "plan": logged_paths(log),
        }  # fmt: skip
        try:
            trajectory_figure(world, [run], args.plot, colour_by=args.colour_by)
        except OSError as err:  # checked before the episode; the location changed since
            raise ConfigError(
                f"--plot {args.plot}: cannot write the figure ({err.strerror}); "
                "the episode's summary is printed above"
            ) from err
        if not args.json:
            print(f"figure: {args.plot}")
    return 0


def figure_suffixes() -> list[str]:
    """File types matplotlib can write (png, pdf, svg, ...), for --plot."""
    # start-up cost: matplotlib (~0.3 s) only with --plot
    from matplotlib.backend_bases import FigureCanvasBase

    return list(FigureCanvasBase.get_supported_filetypes())
