"""``labkit lab`` and ``labkit new``: JupyterLab on the labs, and a new lab for any arm."""

from __future__ import annotations
from labkit.cli._types import port_number


def add_commands(sub):
    """Add ``lab`` and ``new`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("lab", help="open JupyterLab on the labs (default: the notebooks/ folder)")
    sp.add_argument("path", nargs="?", default=None, metavar="PATH",
                    help="folder or notebook to open (default: the labs folder, as `labkit render` finds it)")
    sp.add_argument("--port", type=port_number, default=None, help="TCP port (default 8888 or the next free one)")
    sp.add_argument("--no-browser", action="store_true", help="do not open a browser; print the URL with its token")
    sp.add_argument("--instructor", action="store_true",
                    help="keep nbgrader's instructor tools (Formgrader, Create Assignment, Validate); "
                         "default: a students' JupyterLab without them")
    sp.set_defaults(func=_cmd_lab)

    sp = sub.add_parser("new", help="create a lab folder for a robot file from the generic lab templates")
    sp.add_argument("lab_dir", metavar="LAB_DIR", help="the lab folder to create")
    sp.add_argument("--robot", required=True, metavar="ROBOT_FILE", help="robot file (.toml) or bundled robot name")
    sp.add_argument("--title", default=None, help="lab title (default: from the robot's title)")
    sp.add_argument("--force", action="store_true", help="write into an existing, non-empty folder")
    sp.set_defaults(func=_cmd_new)


def _cmd_lab(args):
    from labkit.labs import serve_lab

    return serve_lab(args.path, port=args.port, no_browser=args.no_browser, instructor=args.instructor)


def _cmd_new(args):
    from labkit.labs import new_lab

    lab = new_lab(args.robot, args.lab_dir, title=args.title, force=args.force)
    print(f"lab created: {lab.folder} ({lab.description}; {len(lab.notebooks)} notebooks, robot file {lab.robot_file.name})")
    for line in lab.notes:  # what the lab added to the robot, and the joint ranges that result
        print(f"  {line}")
    for nb in lab.notebooks:
        print(f"  {nb.name}")
    print(f"open it: labkit lab {lab.folder}    render it: labkit render {lab.folder}")
    return 0
