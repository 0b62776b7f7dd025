"""``labkit assign`` and ``labkit grade``: a course's student versions and autograding.

``labkit render --scheduler`` (in ``_reports``) uses the same batch engine.
"""

from __future__ import annotations

import sys
from pathlib import Path
from labkit.cli._types import bounded_float, positive_int, scheduler_url


def add_commands(sub):
    """Add ``assign`` and ``grade`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("assign", help="write the student version of a tagged lab folder (nbgrader)")
    sp.add_argument("lab_dir", metavar="LAB_DIR", help="instructor lab folder (cells tagged solution/tests/hidden-tests)")
    sp.add_argument("out_dir", metavar="OUT_DIR", help="where the student notebooks go")
    sp.add_argument("--no-baseline", action="store_true",
                    help="do not grade the untouched student version (which checks pass without student work)")
    sp.set_defaults(func=_cmd_assign)

    sp = sub.add_parser("grade", help="grade every submission in a sandbox; gradebook CSV/Excel + HTML feedback pages")
    sp.add_argument("submissions", metavar="SUBMISSIONS_DIR", help="one folder per student with their notebooks")
    sp.add_argument("--lab", required=True, metavar="LAB_DIR", help="the instructor's lab folder (with hidden tests)")
    sp.add_argument("-o", "--output", default="gradebook.csv",
                    help="gradebook .csv (an .xlsx twin is written too) or .xlsx (default gradebook.csv)")
    sp.add_argument("--feedback", metavar="DIR", help="feedback reports folder (default: <gradebook stem>_feedback/)")
    add_engine_options(sp)
    sp.add_argument("--cpu", type=bounded_float(0.1, 86400.0, "s"), default=120.0, metavar="SECONDS", help="CPU time per notebook (default 120)")
    sp.add_argument("--memory", type=bounded_float(0.01, 4096.0, "GiB"), default=4.0, metavar="GIB", help="memory per notebook [GiB] (default 4)")
    sp.add_argument("--wall", type=bounded_float(0.1, 86400.0, "s"), default=300.0, metavar="SECONDS",
                    help="wall-clock time per notebook (default 300)")
    sp.add_argument("--no-sandbox", action="store_true",
                    help="limits only, no bubblewrap (for machines without it; student code then sees every file)")
    sp.add_argument("--no-html", action="store_true", help="skip the HTML feedback pages")
    sp.add_argument("--count-free", action="store_true",
                    help="count the rows the untouched student version already passes (default: worth 0)")
    sp.set_defaults(func=_cmd_grade)


def add_engine_options(sp):
    """Add ``--jobs`` and ``--scheduler`` (the batch engine) to a subcommand's parser.

    Parameters
    ----------
    sp : argparse.ArgumentParser
        The subcommand's parser.
    """
    sp.add_argument("-j", "--jobs", type=positive_int, default=2, help="local worker processes (default 2)")
    sp.add_argument("--scheduler", metavar="tcp://HOST:PORT", type=scheduler_url,
                    help="run on this dask.distributed scheduler instead of the local pool")


def _cmd_assign(args):
    from labkit.course import assign

    result = assign(args.lab_dir, args.out_dir)
    hidden = sum(c.hidden for c in result.checks)
    print(f"{len(result.notebooks)} student notebook(s) in {Path(args.out_dir).resolve()} "
          f"({len(result.checks) - hidden} public checks kept, {hidden} hidden checks removed, "
          f"{len(result.other_files)} other file(s) copied)")
    if not args.no_baseline:
        from labkit.course import baseline

        base = baseline(args.lab_dir)
        kinds = (f"{len(base.reasons)} of them are free (worth 0) and {len(base.derivations)} are derivation rows "
                 "(they count, and earn only with the rows they back)" if base.derivations else
                 "these rows are free (worth 0)")
        print(f"the untouched student version passes {len(base.reasons) + len(base.derivations)} check row(s); at "
              f"grading {kinds}, so it scores 0 and a submission can earn at most {base.max_points:g} points "
              f"(of the {base.result.max_points:g} the checks declare; labkit grade --count-free counts free rows)")
        for line in base.reasons:
            print(f"  free: {line}")
        for line in base.derivations:
            print(f"  derivation: {line}")
    return 0


def _cmd_grade(args):
    from labkit.course import Limits, grade, gradebook_frame, write_gradebook

    out = Path(args.output)
    feedback = Path(args.feedback) if args.feedback else out.with_name(out.stem + "_feedback")
    limits = Limits(cpu_seconds=args.cpu, memory_bytes=int(args.memory * 2**30), wall_seconds=args.wall,
                    sandbox=not args.no_sandbox)
    results = grade(args.submissions, args.lab, feedback, limits=limits, scheduler=args.scheduler, jobs=args.jobs,
                    html=not args.no_html, count_free=args.count_free)
    frame = gradebook_frame(results)
    written = write_gradebook(frame, out)
    not_ok = frame[frame["status"] != "ok"]
    mechanisms = sorted({m for m in frame["memory_limit"] if m})
    if mechanisms:
        print(f"memory limited per notebook run by: {', '.join(mechanisms)}"
              + (" (sampling watchdog: no memory cgroup could be made here)" if "watchdog" in mechanisms else ""))
    print(f"{len(frame)} submissions graded; mean {frame['points'].mean():.2f} / {frame['max_points'].max():g} points; "
          f"gradebook: {', '.join(str(p) for p in written)}; feedback: {feedback.resolve()}")
    if len(not_ok):
        print("not ok: " + ", ".join(f"{s} ({st})" for s, st in not_ok["status"].items()), file=sys.stderr)
    return 0
