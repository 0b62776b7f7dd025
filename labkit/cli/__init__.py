"""The ``labkit`` command line.

Every subcommand's argparse lives in this package, one module per concept
(``_kinematics``: robots, fk, ik; ``_arm``: sim, ports, calibrate-bus; ``_measure``: errors,
audit, calibrate; ``_reports``: run, render, report; ``_labs``: lab, new; ``_course``:
assign, grade), each a thin call into the library. The library modules hold no
command-line code.
"""

from __future__ import annotations

import argparse
import sys

from labkit.cli import _arm, _course, _kinematics, _labs, _measure, _reports, _vision
from labkit.cli._lazy import LazyParser
from labkit.cli._types import OneLineErrors
from labkit.exceptions import LabkitError


class _Parser(OneLineErrors, argparse.ArgumentParser):
    """The top-level parser: usage errors on one line."""



def build_parser():
    """The argparse parser of the ``labkit`` command with every subcommand.

    Returns
    -------
    argparse.ArgumentParser
    """
    p = _Parser(prog="labkit", description="Robotics lab workbench.")
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
        a :class:`LabkitError`, an ``OSError`` (unreadable or unwritable path) or a
        ``ValueError`` (an input file that does not parse), 3 for any other exception;
        the message is printed on stderr as one line, never a traceback (unless the
        environment sets ``LABKIT_DEBUG``).
    """
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except LabkitError as exc:
        _fail(args, exc)
        return 2
    except BrokenPipeError:  # `labkit robots | head`: the reader went away, not an error
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # an unreadable input or unwritable output path
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        _fail(args, f"{where}{exc.strerror or exc} (expected a readable input and a writable output path)")
        return 2
    except (ValueError, UnicodeError) as exc:  # an input file that is not what it should be (e.g. not JSON)
        _fail(args, f"{type(exc).__name__}: {exc} (expected well-formed input files and option values)")
        return 2
    except Exception as exc:  # noqa: BLE001 - never a traceback for a user; LABKIT_DEBUG=1 shows it
        import os

        if os.environ.get("LABKIT_DEBUG"):
            raise
        _fail(args, f"internal error {type(exc).__name__}: {exc} (LABKIT_DEBUG=1 shows the traceback; please report it)")
        return 3


def _fail(args, message):
    """Print ``message`` as one line on stderr, prefixed with the command."""
    text = " ".join(str(message).split())
    print(f"labkit {args.command}: error: {text}", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
