"""``labkit errors``, ``labkit audit``, ``labkit calibrate``: measurement tables at the command line."""

from __future__ import annotations
from labkit.cli._types import finite_float


def add_commands(sub):
    """Add ``errors``, ``audit`` and ``calibrate`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sub.add_parser("errors", help="measured-versus-calculated error table of a measurement CSV",
                   build=_errors_arguments)

    sp = sub.add_parser("audit", help="recompute published calculated values; exit 1 if any disagree")
    sp.add_argument("file", help="published-values CSV (docs/measurements.md section 5)")
    sp.add_argument("--robot", help="robot name or file (default: the file's robot column)")
    sp.add_argument("--branch", help="IK branch for target rows (default: the first branch that reaches each target)")
    sp.set_defaults(func=_cmd_audit)

    sub.add_parser("calibrate", help="fit robot parameters to measured positions", build=_calibrate_arguments)


def _errors_arguments(sp):
    from labkit.measure import COMBINE_RULES  # uncertainty rules offered as choices

    sp.add_argument("file", help="measurement CSV (docs/measurements.md)")
    sp.add_argument("--robot", help="robot name or file (default: the file's robot column)")
    sp.add_argument("--branch", help="IK branch for target rows (default: the first branch that reaches each target)")
    sp.add_argument("--combine", default="quadrature", choices=COMBINE_RULES, help="uncertainty rule")
    sp.add_argument("--html", help="also write the styled table as HTML")
    sp.add_argument("--latex", help="also write the styled table as LaTeX")
    sp.set_defaults(func=_cmd_errors)


def _calibrate_arguments(sp):
    from labkit.measure import GROUPS  # calibration parameter groups

    sp.add_argument("file", help="measurement CSV with commanded joints and x/y/z readings")
    sp.add_argument("--robot", help="robot name or file (default: the file's robot column)")
    sp.add_argument("--params", nargs="+", default=["joint_offsets", "link_lengths"],
                    help=f"groups {GROUPS} or names like offset[2] a[3] tool_x sag[2]")
    sp.add_argument("--gravity", nargs=3, type=finite_float, default=None, metavar=("GX", "GY", "GZ"),
                    help="gravity direction in world coordinates (for sag terms; default: minus the robot file's up)")
    sp.add_argument("--weighted", action="store_true", help="weight residuals by 1/uncertainty")
    sp.add_argument("--out", help="write the calibrated robot file here")
    sp.set_defaults(func=_cmd_calibrate)


def _cmd_errors(args):
    from labkit.measure import error_table
    from labkit.tables import report_table

    result = error_table(args.robot, args.file, branch=args.branch, combine=args.combine)
    print(result.report_table(pose="pose_id").to_text())  # the table the HTML, the LaTeX and a report print
    print()
    print(report_table(result.summary, columns=_SUMMARY_COLUMNS, digits=3).to_text())
    if args.html:
        result.to_html(args.html)
    if args.latex:
        result.to_latex(args.latex)
    return 0


#: the summary of an error table, as ``labkit errors`` prints it
_SUMMARY_COLUMNS = {"n_poses": "poses", "rms_error": "RMS error", "max_abs_error": "max |error|",
                    "mean_error": "mean error", "n_inside": "within U"}


def _cmd_audit(args):
    from labkit.measure import audit_published

    audit = audit_published(args.robot, args.file, branch=args.branch)
    flagged = audit.flagged
    print(f"{len(audit.cells) - len(flagged)} of {len(audit.cells)} published values agree with the model")
    if len(flagged):
        print(flagged.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    return 1 if len(flagged) else 0


def _cmd_calibrate(args):
    from labkit.measure import calibrate

    result = calibrate(args.robot, args.file, params=tuple(args.params), weighted=args.weighted,
                       gravity=None if args.gravity is None else tuple(args.gravity))
    print(result.parameters().to_string(float_format=lambda v: f"{v:.3f}"))
    print(result.summary())
    if args.out:
        result.write_robot(args.out)
        print(f"calibrated robot written to {args.out}")
    return 0
