"""``labkit sim``: serve the virtual arm on a pseudo-terminal for any serial tool."""

from __future__ import annotations

import sys


def add_commands(sub):
    """Add ``sim`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("sim", help="serve the virtual arm on a pseudo-terminal (prints the port path)")
    sp.add_argument("robot", nargs="?", default="arduino_arm_3dof", help="bundled robot name or robot file")
    sp.add_argument("--seed", type=int, default=0, help="physics seed (offsets, noise)")
    sp.add_argument("--time-scale", type=float, default=1.0, help="board seconds per wall-clock second")
    sp.set_defaults(func=_cmd_sim)


def _cmd_sim(args):
    from labkit.arm import make_board, serve_pty

    board = make_board(args.robot, seed=args.seed)

    def announce(path):
        print(path, flush=True)
        print(f"virtual {board.robot.name} (seed {args.seed}) on {path}; Ctrl-C to stop", file=sys.stderr, flush=True)

    try:
        serve_pty(board, time_scale=args.time_scale, announce=announce)
    except KeyboardInterrupt:
        pass
    return 0
