"""Points: how the rows of a lab's checks become points. The one place these rules are written.

Grading (:func:`labkit.course.grade_submission`), the untouched student version's grading
(:func:`labkit.course.baseline`, whose maximum ``labkit assign`` prints), the gradebook and
the feedback pages all score through :func:`score_notebook`:

1. A check's points are shared by its rows that **count**; a check whose rows all are free
   is worth 0.
2. A row that passes on the untouched student version is **free** (worth 0), unless it is a
   derivation row.
3. A **derivation row** passes untouched but reads a value of the student's kernel that a row
   needing work (one that fails untouched) also reads: directly, through the check's set-up
   statements, or through the lab's own cells that compute it (``frames = fk_frames(arm, q)``
   makes ``frames`` a value of ``q``). Such a row proves that the value the student's answer is
   compared with is still the lab's (``FK(q) - target``, with the target from the trusted
   parameters cell): it counts. Rows that share such values form a **group**: a row needing
   work earns its share only when every derivation row of its group passes, and a derivation
   row earns its share only when it passes and every row needing work of its group passes.
   So overwriting the lab's ``q`` with a fake and giving steps that agree with it earns nothing
   in that group, and the untouched version still scores 0.

Values the checker takes from the instructor (the imports and definitions of the prelude, the
``parameters`` and ``reference`` cells) are trusted: the student's kernel cannot change them,
so they link no rows.

Example
-------
>>> from labkit.course._points import link_rows
>>> values = {("c", 0): {"t", "q"}, ("c", 1): {"q"}, ("c", 2): {"T_other"}}
>>> links = link_rows(values, untouched={("c", 1), ("c", 2)})
>>> sorted(links.free), sorted(links.derivations)
([('c', 2)], [('c', 1)])
>>> links.voided({("c", 0): True, ("c", 1): False, ("c", 2): True})[("c", 0)][:13]
'earns nothing'
"""

from __future__ import annotations

import ast
from dataclasses import dataclass

from labkit.course._assign import (HIDDEN_TESTS_TAG, PARAMETERS_TAG, REFERENCE_TAG, SOLUTION_TAG, TESTS_TAG, cell_role,
                                   graded_cells)
from labkit.course._plan import _BUILTINS, _bound_inside, _stores, plan_check, prelude_source, python_source
from labkit.course._submission import clean_text

__all__ = ["RowScore", "CellScore", "RowLinks", "row_values", "link_rows", "score_notebook", "unscored"]


@dataclass(frozen=True)
class RowScore:
    """The score of one row of a check.

    Attributes
    ----------
    name : str
        Row name.
    points, max_points : float
        Earned and possible [points] (0 / 0 for a free row).
    passed : bool
        The row passed and earned its share (False for a row voided by its group, see the module).
    free : bool
        The row passes on the untouched student version and proves nothing (worth nothing).
    error : str
        What failed (exception type and message, the failing comparison, or why the group voids it).
    line : int
        Line of the row in the check cell.
    """

    name: str
    points: float
    max_points: float
    passed: bool
    free: bool = False
    error: str = ""
    line: int = 0


@dataclass(frozen=True)
class CellScore:
    """The score of one check (one ``tests`` or ``hidden-tests`` cell) of one submission.

    Attributes
    ----------
    notebook, name : str
        Notebook file name and check name.
    points, max_points : float
        Points earned and possible [points]: the check's weight shared by its rows that are
        not free (a check whose rows are all free is worth 0).
    hidden : bool
        True for a hidden check.
    passed : bool
        True when every row passed.
    rows : tuple of RowScore
    cell_id : str
    """

    notebook: str
    name: str
    points: float
    max_points: float
    hidden: bool
    passed: bool
    rows: tuple = ()
    cell_id: str = ""

    @property
    def free(self) -> bool:
        """Every row passes without student work (the check is worth 0)."""
        return bool(self.rows) and all(r.free for r in self.rows)


def _loads(stmt) -> set:
    names = {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
    return names - _bound_inside(stmt) - _BUILTINS


def _statements(text):
    try:
        return ast.parse(text).body
    except SyntaxError:
        return []


def _expand(names, deps) -> set:
    """``names`` and every name they are computed from, through ``deps`` (transitively)."""
    out, todo = set(), list(names)
    while todo:
        name = todo.pop()
        if name not in out:
            out.add(name)
            todo.extend(deps.get(name, ()))
    return out


def row_values(source, plans) -> dict:
    """The values of the student's kernel each row of a notebook's checks depends on.

    Parameters
    ----------
    source : nbformat.NotebookNode
        The instructor's notebook.
    plans : dict of str to CheckPlan
        The notebook's check cells by cell id (:func:`labkit.course._plan.plan_check`).

    Returns
    -------
    dict
        ``{(cell id, row index): frozenset of names}``: the names the row reads, directly or through
        its check's set-up and the lab's own cells (not the solution cells: their names are answers),
        without the trusted ones (prelude, ``parameters`` and ``reference`` cells) and builtins.
    """
    code = [c for c in source.cells if c.cell_type == "code"]
    trusted = set()
    for text in prelude_source((c.source, cell_role(c) == SOLUTION_TAG) for c in code):
        trusted |= {n for stmt in _statements(text) for n in _stores(stmt)}
    lab_deps = {}
    for cell in code:
        role = cell_role(cell)
        if role in (PARAMETERS_TAG, REFERENCE_TAG):
            trusted |= {n for stmt in _statements(python_source(cell.source)) for n in _stores(stmt)}
        elif role not in (SOLUTION_TAG, TESTS_TAG, HIDDEN_TESTS_TAG):
            for stmt in _statements(python_source(cell.source)):
                for name in _stores(stmt):
                    lab_deps.setdefault(name, set()).update(_loads(stmt))
    out = {}
    for cell_id, plan in plans.items():
        local = {}  # names the check's set-up assigns -> the names they were computed from
        rows = {row.statement: row for row in plan.rows}
        for i, (text, _, kind) in enumerate(plan.statements):
            reads = set()
            for stmt in _statements(text):
                reads |= {m for n in _loads(stmt) for m in (local.get(n, {n}))}
            if kind == "setup":
                for stmt in _statements(text):
                    for name in _stores(stmt):
                        local[name] = reads
            elif i in rows:
                values = {n for n in _expand(reads - trusted, {k: v - trusted for k, v in lab_deps.items()})}
                out[(cell_id, rows[i].index)] = frozenset(values - trusted - _BUILTINS)
    return out


@dataclass(frozen=True)
class RowLinks:
    """Which rows of a notebook are free, which prove a value, and how rows are grouped (see the module).

    Attributes
    ----------
    free : frozenset of (str, int)
        ``(cell id, row index)`` of the rows worth nothing.
    derivations : frozenset of (str, int)
        Rows that pass untouched but prove a value a row needing work reads (they count).
    groups : tuple of (frozenset, frozenset, frozenset)
        ``(rows needing work, derivation rows, the values they share)`` of every group holding a
        derivation row.
    """

    free: frozenset = frozenset()
    derivations: frozenset = frozenset()
    groups: tuple = ()

    def voided(self, passed) -> dict:
        """The rows that passed but earn nothing because of their group, and why.

        Parameters
        ----------
        passed : dict
            ``{(cell id, row index): bool}``: the checker's verdict on each row.

        Returns
        -------
        dict
            ``{(cell id, row index): reason}``.
        """
        out = {}
        for work, derivations, shared in self.groups:
            names = ", ".join(sorted(shared)[:4])
            failed = sorted(d for d in derivations if not passed.get(d))
            for row in sorted(work):
                if failed and passed.get(row):
                    out[row] = (f"earns nothing: a row that checks {names} against the lab's values failed, "
                                "so the values this row compares are not the lab's")
            for row in sorted(derivations):
                if passed.get(row) and (failed or not all(passed.get(w) for w in work)):
                    out[row] = (f"earns its share only with the rows it backs: it checks {names}, "
                                "which rows needing work read, and not all of them passed")
        return out


def link_rows(values, untouched) -> RowLinks:
    """Free rows, derivation rows and groups of one notebook's rows (the module's rules 2 and 3).

    Parameters
    ----------
    values : dict
        ``{(cell id, row index): set of names}`` (:func:`row_values`).
    untouched : set of (str, int)
        The rows the untouched student version passes.

    Returns
    -------
    RowLinks
    """
    untouched = set(untouched) & set(values)
    work = [k for k in values if k not in untouched]
    needed = set().union(*(values[k] for k in work)) if work else set()
    derivations = {k for k in untouched if values[k] & needed}
    linked = sorted(work + sorted(derivations))
    parent = {k: k for k in linked}

    def root(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    owner = {}
    for k in linked:
        for name in values[k]:
            if name in owner:
                parent[root(k)] = root(owner[name])
            else:
                owner[name] = k
    members = {}
    for k in linked:
        members.setdefault(root(k), []).append(k)
    groups = []
    for rows in members.values():
        derived = frozenset(r for r in rows if r in derivations)
        if derived:
            needs = frozenset(r for r in rows if r not in derivations)
            shared = frozenset().union(*(values[d] for d in derived)) & frozenset().union(*(values[w] for w in needs))
            groups.append((needs, derived, shared))
    return RowLinks(frozenset(untouched - derivations), frozenset(derivations), tuple(groups))


def _score(chk, plan, results, free_rows, void) -> CellScore:
    counted = [r for r in plan.rows if r.index not in free_rows]
    share = chk.points / len(counted) if counted else 0.0
    rows = []
    for r, res in zip(plan.rows, results):
        is_free = r.index in free_rows
        passed = bool(res.get("passed")) and r.index not in void
        error = void.get(r.index) or res.get("error", "")
        rows.append(RowScore(r.name, share if passed and not is_free else 0.0, 0.0 if is_free else share, passed,
                             is_free, clean_text(error, 500), int(res.get("line", r.line))))
    return CellScore(chk.notebook, chk.name, round(sum(r.points for r in rows), 9),
                     round(sum(r.max_points for r in rows), 9), chk.hidden, all(r.passed for r in rows),
                     tuple(rows), chk.cell_id)


def score_notebook(source, name, results, untouched, plans=None) -> list:
    """Score every check of one notebook from the checker's per-row verdicts.

    Parameters
    ----------
    source : nbformat.NotebookNode
        The instructor's notebook.
    name : str
        Its file name.
    results : dict
        ``{cell id: [{"passed": bool, "error": str, "line": int}, ...]}`` (one per row; a missing
        cell's rows fail, "not graded").
    untouched : dict
        ``{(notebook, cell id): set of row indices}`` the untouched student version passes
        (:attr:`labkit.course.Baseline.free`; empty: every row counts and no group applies).
    plans : dict of str to CheckPlan, optional
        The check cells' plans (default: planned from ``source``).

    Returns
    -------
    list of CellScore
        One per check, in cell order.
    """
    checks = graded_cells(source, name)
    if plans is None:
        texts = {str(c.get("id")): c.source for c in source.cells}
        plans = {chk.cell_id: plan_check(texts[chk.cell_id], chk.cell_id, chk.name) for chk in checks}
    passed_untouched = {(cid, i) for (nb, cid), rows in untouched.items() if nb == name for i in rows}
    links = link_rows(row_values(source, plans), passed_untouched) if passed_untouched else RowLinks()
    verdicts = {}
    for chk in checks:
        rows = results.get(chk.cell_id) or [{"passed": False, "error": "not graded", "line": r.line}
                                            for r in plans[chk.cell_id].rows]
        verdicts[chk.cell_id] = rows
    void = links.voided({(cid, i): bool(r.get("passed")) for cid, rows in verdicts.items() for i, r in enumerate(rows)})
    scores = []
    for chk in checks:
        free_rows = {i for cid, i in links.free if cid == chk.cell_id}
        cell_void = {i: why for (cid, i), why in void.items() if cid == chk.cell_id}
        scores.append(_score(chk, plans[chk.cell_id], verdicts[chk.cell_id], free_rows, cell_void))
    return scores


def unscored(sources, untouched, why="not graded") -> tuple:
    """Every check of the lab at 0 points, for a submission that could not run (its maximum as any other's).

    Parameters
    ----------
    sources : dict of str to nbformat.NotebookNode
        The instructor's notebooks by file name.
    untouched : dict
        As for :func:`score_notebook`.
    why : str
        The rows' error.

    Returns
    -------
    tuple of CellScore
    """
    scores = []
    for name, nb in sources.items():
        texts = {str(c.get("id")): c.source for c in nb.cells}
        plans = {chk.cell_id: plan_check(texts[chk.cell_id], chk.cell_id, chk.name) for chk in graded_cells(nb, name)}
        results = {cid: [{"passed": False, "error": why, "line": r.line} for r in plan.rows] for cid, plan in plans.items()}
        scores += score_notebook(nb, name, results, untouched, plans)
    return tuple(scores)
