"""``labkit sim``: serve the virtual arm on a pseudo-terminal for any serial tool;
``labkit ports``: list the serial ports, likely Arduinos marked; ``labkit calibrate-bus``: a bus arm's
zeros, directions and limits, moved by hand step by step, written into its robot file."""

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
    sp = sub.add_parser("calibrate-bus", help="calibrate a servo-bus arm by hand (torque off): bus zeros, directions "
                        "and limits into its robot file")
    sp.add_argument("robot", help="robot file with a [bus] table (calibrated in place, the old file kept as .bak)")
    sp.add_argument("--port", required=True, help="the bus: dynamixel:///dev/ttyUSB0, feetech:///dev/ttyACM0 "
                    "(?baud=..&latency=..), or sim://?bus=feetech&seed=N (a virtual arm mounted at random, "
                    "moved by a virtual hand)")
    sp.add_argument("--out", help="write the calibrated robot file here instead (required for a bundled robot)")
    sp.add_argument("--no-backup", action="store_true", help="calibrating in place: keep no .bak of the old file")
    sp.add_argument("--no-rehome", action="store_true", help="never write a servo's homing offset (a range across the "
                    "encoder's seam is then an error saying how to re-home)")
    sp.add_argument("--dry-run", action="store_true", help="show the calibration; write no file and no homing offset")
    sp.set_defaults(func=_cmd_calibrate_bus)


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


def _shown(text):
    """``text`` with every control character but newlines shown as an escape (robot files are untrusted)."""
    return "".join(c if c.isprintable() or c == "\n" else repr(c)[1:-1] for c in str(text))


def _cmd_calibrate_bus(args):
    from labkit.arm import calibrate_bus

    def say(text):
        print(_shown(text), flush=True)

    result = calibrate_bus(args.robot, args.port, out=args.out, say=say, backup=not args.no_backup,
                           write=not args.dry_run, rehome=not args.no_rehome)
    print("\nbefore -> after:")
    print(_shown(result.table()))
    if result.path is not None:
        print(_shown(f"\nwrote {result.path}" + (f" (old file kept as {result.backup})" if result.backup else "")))
        print(_shown(result.diff) or "(no line changed)", end="" if result.diff else "\n")
    else:
        print("\n(dry run: no file written)")
    return 0
