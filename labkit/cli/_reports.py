"""``labkit run``, ``labkit render`` and ``labkit report``: execute lab notebooks, render reports."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from labkit.cli._types import positive_float, positive_int, scheduler_url


def add_commands(sub):
    """Add ``run``, ``render`` and ``report`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("run", help="execute one lab notebook (papermill) with parameter overrides")
    sp.add_argument("notebook", help="the .ipynb to execute")
    sp.add_argument("-p", "--parameter", dest="parameters", nargs=2, action="append", metavar=("NAME", "VALUE"),
                    help="override a parameter (repeatable), e.g. -p port /dev/ttyACM0")
    sp.add_argument("-o", "--output", help="executed notebook (default reports/<lab>/<name>.ipynb)")
    sp.add_argument("--html", action="store_true", help="also write the offline HTML report next to it")
    sp.add_argument("--no-input", action="store_true", help="report mode: hide code in the HTML")
    sp.set_defaults(func=_cmd_run)

    sub.add_parser("render", help="execute notebooks in parallel and write HTML/PDF reports + index",
                   build=_render_arguments)
    sub.add_parser("report", help="one report per lab: title page, contents, a chapter per notebook (PDF/HTML/DOCX)",
                   build=_report_arguments)


def _report_arguments(sp):
    sp.add_argument("lab", metavar="LAB_DIR", help="the lab folder (e.g. notebooks/seed000_arduino_arm)")
    sp.add_argument("-o", "--output", help="report file without suffix, or a folder (default reports/<lab>)")
    sp.add_argument("--to", default="pdf,html", help="formats, comma-separated: pdf,html,docx (default pdf,html)")
    sp.add_argument("--show-code", action="store_true", help="keep the code in the chapters (default: appendix A)")
    sp.add_argument("--executed", metavar="DIR",
                    help="use the executed notebooks in DIR (e.g. reports/<lab> of labkit render) instead of running")
    sp.add_argument("-j", "--jobs", type=int, default=2, help="parallel kernels (default 2)")
    sp.add_argument("-p", "--parameter", dest="parameters", nargs=2, action="append", metavar=("NAME", "VALUE"),
                    help="override a parameter in every notebook that declares it, e.g. -p port sim://")
    sp.add_argument("--timeout", type=float, default=None, metavar="SECONDS", help="seconds one cell may run")
    sp.set_defaults(func=_cmd_report)


def _cmd_report(args):
    from labkit.reports import build_report

    lab = Path(args.lab)
    if not lab.is_dir():  # a lab name under notebooks/
        from labkit.reports import notebooks_root

        lab = notebooks_root() / args.lab
    res = build_report(lab, args.output, to=args.to.split(","), show_code=args.show_code, executed=args.executed,
                       jobs=args.jobs, parameters=_parse_params(args.parameters), timeout=args.timeout)
    for kind, path in res.files.items():
        inside = Path(path).resolve().is_relative_to(Path.cwd().resolve())
        print(f"{kind}: {os.path.relpath(path) if inside else path}")
    for line in res.errors:
        print(f"error: {line}", file=sys.stderr)
    if not res.ok:
        print(f"labkit report: {len(res.errors)} notebook(s) failed, {len(res.warnings)} unresolved reference(s)",
              file=sys.stderr)
        return 1
    return 0


def _render_arguments(sp):
    from labkit.reports import CELL_TIMEOUT  # seconds one notebook cell may run (default of --timeout)

    sp.add_argument("notebooks", nargs="*", metavar="NOTEBOOK_OR_LAB",
                    help="notebooks, lab folders or lab names (default: all under notebooks/)")
    sp.add_argument("-j", "--jobs", type=positive_int, default=2, help="parallel worker processes (default 2)")
    sp.add_argument("--scheduler", metavar="tcp://HOST:PORT", type=scheduler_url,
                    help="run on this dask.distributed scheduler (workers need labkit, and Chromium for PDFs)")
    sp.add_argument("--no-input", action="store_true", help="report mode: hide code cells")
    sp.add_argument("--pdf", action=argparse.BooleanOptionalAction, default=True,
                    help="print each report to PDF with headless Chromium (default on)")
    sp.add_argument("-o", "--output", default="reports", help="reports folder (default reports/)")
    sp.add_argument("-p", "--parameter", dest="parameters", nargs=2, action="append", metavar=("NAME", "VALUE"),
                    help="override a parameter in every notebook that declares it, e.g. -p port sim://")
    sp.add_argument("--timeout", type=positive_float, default=None, metavar="SECONDS",
                    help=f"seconds one cell may run before the notebook fails (default {CELL_TIMEOUT})")
    sp.set_defaults(func=_cmd_render)


def _parse_params(pairs):
    from labkit.reports import parse_parameter

    return {name: parse_parameter(value) for name, value in (pairs or [])}


def _cmd_run(args):
    from labkit.reports import execute_notebook, export_html, lab_of

    nb = Path(args.notebook)
    out = Path(args.output) if args.output else Path("reports") / lab_of(nb) / nb.name
    res = execute_notebook(nb, out, _parse_params(args.parameters))
    print(f"{'ok' if res.ok else 'FAILED'}: {nb} -> {res.output} ({res.seconds:.1f} s)")
    if args.html:
        html = export_html(res.output, out.with_suffix(".html"), no_input=args.no_input, title=nb.stem,
                           status="passed" if res.ok else "failed", error=res.error)
        print(f"report: {html}")
    if not res.ok:
        print(f"error: {res.error}", file=sys.stderr)
        return 1
    return 0


def _cmd_render(args):
    from labkit.reports import render
    from labkit.course import render_batch

    if args.scheduler:  # portable tasks: notebooks shipped to the workers, reports written here
        results, wall = render_batch(args.notebooks, args.output, scheduler=args.scheduler, no_input=args.no_input,
                                     pdf=args.pdf, parameters=_parse_params(args.parameters), timeout=args.timeout)
    else:
        results, wall = render(args.notebooks, args.output, jobs=args.jobs, no_input=args.no_input, pdf=args.pdf,
                               parameters=_parse_params(args.parameters), timeout=args.timeout)
    failed = [r for r in results if not r.ok]
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{len(results)} notebooks rendered in {wall:.1f} s (wall time, --jobs {args.jobs}, {os.cpu_count()} CPUs; "
          f"CPU time {usage.ru_utime + usage.ru_stime:.1f} s, load average {load:.1f}); "
          f"index: {Path(args.output).resolve() / 'index.html'}")
    if failed:
        print(f"FAILED ({len(failed)}): " + ", ".join(f"{r.lab}/{r.name}" for r in failed), file=sys.stderr)
        return 1
    return 0
