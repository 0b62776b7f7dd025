"""``labkit sim``: serve the virtual arm on a pseudo-terminal for any serial tool;
``labkit ports``: list the serial ports, likely Arduinos marked."""

from __future__ import annotations

import sys
from labkit.cli._types import positive_float


def add_commands(sub):
    """Add ``sim`` and ``ports`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("sim", help="serve the virtual arm on a pseudo-terminal (prints the port path)")
    sp.add_argument("robot", help="bundled robot name or robot file (e.g. arduino_arm_3dof)")
    sp.add_argument("--seed", type=int, default=0, help="physics seed (offsets, noise)")
    sp.add_argument("--time-scale", type=positive_float, default=1.0, help="board seconds per wall-clock second")
    sp.set_defaults(func=_cmd_sim)
    sp = sub.add_parser("ports", help="list serial ports (USB VID:PID; likely Arduinos marked with *)")
    sp.set_defaults(func=_cmd_ports)


def _cmd_ports(args):
    from labkit.arm import list_ports

    ports = list_ports()
    if not ports:
        print("no serial ports found (plug the board in; the virtual arm is 'sim://')")
        return 0
    width = max(len(p.device) for p in ports)
    for p in ports:
        print(f"{'*' if p.arduino else 'b' if p.bus_adapter else ' '} {p.device:<{width}}  {p.usb_id:<9}  {p.description}")
    if any(p.arduino for p in ports):
        print("* looks like an Arduino; Arm(robot) without a port takes the first of these")
    if any(p.bus_adapter for p in ports):
        print("b may be a servo-bus adapter (FTDI, e.g. a U2D2): dynamixel://<port> or feetech://<port>")
    return 0


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
