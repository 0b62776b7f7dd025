"""The ``labkit`` command line.

Every subcommand's argparse lives in this package, one module per concept
(``_kinematics``: robots, fk, ik; ``_arm``: sim, ports; ``_measure``: errors,
audit, calibrate; ``_reports``: run, render, report; ``_labs``: lab, new; ``_course``:
assign, grade), each a thin call into the library. The library modules hold no
command-line code.
"""

from __future__ import annotations

import argparse
import sys

from labkit.cli import _arm, _course, _kinematics, _labs, _measure, _reports, _vision
from labkit.cli._lazy import LazyParser
from labkit.exceptions import LabkitError



def build_parser():
    """The argparse parser of the ``labkit`` command with every subcommand.

    Returns
    -------
    argparse.ArgumentParser
    """
    p = argparse.ArgumentParser(prog="labkit", description="Robotics lab workbench.")
    # subcommands add their arguments on first use: `labkit --help` imports no numerical library
    sub = p.add_subparsers(dest="command", required=True, parser_class=LazyParser)
    for module in (_kinematics, _arm, _reports, _labs, _measure, _course, _vision):
        module.add_commands(sub)
    return p


def main(argv=None):
    """Entry point of the ``labkit`` console script.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments without the program name; default
        ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status: the subcommand's status (0 on success), 2 when it raised
        a :class:`LabkitError` (the message is printed on stderr).
    """
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except LabkitError as exc:
        print(f"labkit {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `labkit robots | head`: the reader went away, not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
