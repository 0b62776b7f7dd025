"""Reading a check cell with ``ast``: the names it reads, its rows, and the instructor's trusted definitions.

A check cell (``tests`` or ``hidden-tests``) is split into top-level statements:

* a **row** is a statement that checks something: a ``checks.check(...)`` /
  ``checks.typo(...)`` / ``check(...)`` call, an ``assert``, or a compound statement
  (``for``, ``if``, ``with``) holding such calls; each row is scored on its own
  (partial credit inside a cell);
* ``checks.assert_all()`` is left out (the grader gives the verdict, per row);
* everything else is **setup** (``r = np.linalg.norm(...)``), run in order before the
  rows that follow it.

A cell with no row is one row: it passes when it runs without an error.

The **free names** of a cell are the names it reads before assigning them: the values
the student's kernel hands out at that point (:mod:`labkit.course._wire`). The
**prelude** of a lab notebook is the instructor's trusted code that the checker runs
first: the imports of every cell and the ``def`` / ``class`` statements and
``Checks(...)`` objects of the cells that are not student work.

Example
-------
>>> from labkit.course._plan import plan_check
>>> plan = plan_check("r = abs(x)\\nchecks.check('r', r, 1, tol=0)\\nassert y > 0\\nchecks.assert_all()", "c1", "demo")
>>> plan.free_names, [row.name for row in plan.rows]
(('checks', 'x', 'y'), ['r', 'demo: assertion 2'])
"""

from __future__ import annotations

import ast
import builtins
from dataclasses import dataclass

__all__ = ["Row", "CheckPlan", "python_source", "plan_check", "prelude_source", "checks_names"]

_ROW_CALLS = ("check", "typo")
_BUILTINS = frozenset(dir(builtins))


@dataclass(frozen=True)
class Row:
    """One scored row of a check cell.

    Attributes
    ----------
    index : int
        Position among the cell's rows (0-based).
    name : str
        The row's name (the first argument of ``checks.check`` when it is a string literal).
    statement : int
        Index of the statement (in :attr:`CheckPlan.statements`) that is this row.
    line : int
        Line of the row in the cell (1-based).
    """

    index: int
    name: str
    statement: int
    line: int


@dataclass(frozen=True)
class CheckPlan:
    """How one check cell is exported and run.

    Attributes
    ----------
    cell_id, name : str
        The cell's id and check name.
    free_names : tuple of str
        Names the cell reads before assigning them (sorted).
    statements : tuple of (str, int, str)
        ``(source, first line, kind)`` of each top-level statement; kind ``"row"``,
        ``"setup"`` or ``"skip"``.
    rows : tuple of Row
    error : str
        Why the cell could not be parsed ("" if it could; then it is one failing row).
    """

    cell_id: str
    name: str
    free_names: tuple
    statements: tuple
    rows: tuple
    error: str = ""


def python_source(source) -> str:
    """Cell text with IPython syntax (``%magic``, ``!cmd``) turned into Python.

    Parameters
    ----------
    source : str
        The cell's text.

    Returns
    -------
    str
    """
    try:
        from IPython.core.inputtransformer2 import TransformerManager

        return TransformerManager().transform_cell(str(source))
    except Exception:
        return str(source)


def _is_row_call(node) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Attribute) and f.attr in _ROW_CALLS) or (isinstance(f, ast.Name) and f.id == "check")


def _is_assert_all(stmt) -> bool:
    return (isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call)
            and isinstance(stmt.value.func, ast.Attribute) and stmt.value.func.attr == "assert_all")


def _row_name(stmt, cell_name, k) -> str:
    for node in ast.walk(stmt):
        if _is_row_call(node) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            return node.args[0].value
    kind = "assertion" if isinstance(stmt, ast.Assert) else "check"
    return f"{cell_name}: {kind} {k + 1}"


def _bound_inside(stmt) -> set:
    """Names bound by comprehensions, lambdas and nested functions inside ``stmt`` (their own scopes)."""
    bound = set()
    for node in ast.walk(stmt):
        if isinstance(node, (ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)):
            for gen in node.generators:
                bound |= {n.id for n in ast.walk(gen.target) if isinstance(n, ast.Name)}
        elif isinstance(node, (ast.Lambda, ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            bound |= {x.arg for x in a.posonlyargs + a.args + a.kwonlyargs}
            bound |= {x.arg for x in (a.vararg, a.kwarg) if x is not None}
    return bound


def _stores(stmt) -> set:
    names = {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, (ast.Store, ast.Del))}
    for node in ast.walk(stmt):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
    return names


def plan_check(source, cell_id, name) -> CheckPlan:
    """Split a check cell into setup and rows and find the names it reads.

    Parameters
    ----------
    source : str
        The instructor's cell text.
    cell_id, name : str
        The cell's id and check name.

    Returns
    -------
    CheckPlan
    """
    text = python_source(source)
    try:
        tree = ast.parse(text)
    except SyntaxError as exc:
        return CheckPlan(str(cell_id), str(name), (), ((text, 1, "row"),),
                         (Row(0, str(name), 0, 1),), f"SyntaxError: {exc.msg} (line {exc.lineno})")
    lines = text.splitlines()
    assigned, free, statements, rows = set(), set(), [], []
    for stmt in tree.body:
        loads = {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
        free |= loads - assigned - _bound_inside(stmt) - _BUILTINS
        assigned |= _stores(stmt)
        segment = "\n".join(lines[stmt.lineno - 1:stmt.end_lineno])
        if _is_assert_all(stmt):
            kind = "skip"
        elif isinstance(stmt, ast.Assert) or any(_is_row_call(n) or isinstance(n, ast.Assert) for n in ast.walk(stmt)):
            kind = "row"
            rows.append(Row(len(rows), _row_name(stmt, name, len(rows)), len(statements), stmt.lineno))
        else:
            kind = "setup"
        statements.append((segment, stmt.lineno, kind))
    if not rows:  # no recognisable row: the whole cell is one check
        statements = [(s, line, "setup" if kind == "setup" else kind) for s, line, kind in statements]
        statements.append(("pass", len(lines) + 1, "row"))
        rows.append(Row(0, str(name), len(statements) - 1, 1))
    return CheckPlan(str(cell_id), str(name), tuple(sorted(free)), tuple(statements), tuple(rows))


def _is_checks_call(node) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Name) and f.id == "Checks") or (isinstance(f, ast.Attribute) and f.attr == "Checks")


def checks_names(sources) -> set:
    """Names the instructor binds to ``Checks(...)`` objects in the given cells.

    Parameters
    ----------
    sources : iterable of str

    Returns
    -------
    set of str
    """
    names = set()
    for source in sources:
        try:
            tree = ast.parse(python_source(source))
        except SyntaxError:
            continue
        for stmt in tree.body:
            if isinstance(stmt, ast.Assign) and _is_checks_call(stmt.value):
                names |= {t.id for t in stmt.targets if isinstance(t, ast.Name)}
    return names


def prelude_source(cells) -> tuple:
    """The instructor's trusted code the checker runs before the checks of a notebook.

    Parameters
    ----------
    cells : iterable of (str, bool)
        ``(source, is_student_work)`` of the instructor notebook's code cells, in order.

    Returns
    -------
    tuple of str
        The statements: the imports of every cell, and the ``def`` / ``class`` statements and
        ``X = Checks(...)`` assignments of the cells that are not student work, in order.
    """
    keep = []
    for source, student_work in cells:
        text = python_source(source)
        try:
            tree = ast.parse(text)
        except SyntaxError:
            continue
        lines = text.splitlines()
        for stmt in tree.body:
            trusted = isinstance(stmt, (ast.Import, ast.ImportFrom)) or (not student_work and (
                isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
                or (isinstance(stmt, ast.Assign) and _is_checks_call(stmt.value))))
            if trusted:
                start = min([stmt.lineno] + [d.lineno for d in getattr(stmt, "decorator_list", [])])
                keep.append("\n".join(lines[start - 1:stmt.end_lineno]))
    return tuple(keep)
