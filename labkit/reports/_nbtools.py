"""Small helpers for writing lab notebooks.

* :func:`show_latex` - display a sympy expression / matrix (or a LaTeX string) as math;
* :func:`matrix_latex` - LaTeX of a numeric matrix with a fixed number of decimals;
* :class:`Checks` - the closing assertions of a notebook: each :meth:`Checks.check`
  compares a reproduced number with the published one within a documented
  tolerance, :meth:`Checks.typo` records a published number that is wrong (shown,
  never failing), and :meth:`Checks.assert_all` shows the table and raises
  ``AssertionError`` naming the failures;
* :func:`check` - one immediate check (prints a row, raises on failure).

Nothing heavy is imported at module import (IPython only when displaying).

Example
-------
>>> from labkit.reports import Checks
>>> checks = Checks(display=False)
>>> row = checks.check("tau", [2.0, 3.0, 1.0], [2, 3, 1], tol=1e-9, note="seed 002 sec. 3.2")
>>> row.passed
True
>>> checks.assert_all()
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from labkit.exceptions import CheckFailed, ShapeError, needs_extra
from labkit.tables import format_value, report_table

__all__ = ["Comparison", "Checks", "check", "show_latex", "matrix_latex"]


def _display(obj):
    try:
        from IPython import get_ipython
        from IPython.display import display

        if get_ipython() is not None:
            display(obj)
            return True
    except ImportError:  # pragma: no cover - IPython is a dependency of ipykernel
        pass
    return False


def _in_ipython() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover
        return False
    return get_ipython() is not None


def _display_raw(bundle):
    """Display a MIME bundle (dict) in IPython; False outside IPython."""
    try:
        from IPython import get_ipython
        from IPython.display import display

        if get_ipython() is not None:
            display(bundle, raw=True)
            return True
    except ImportError:  # pragma: no cover
        pass
    return False


def matrix_latex(a, decimals=4) -> str:
    """LaTeX ``bmatrix`` of a numeric array of shape (m, n) or (n,) (a column).

    Parameters
    ----------
    a : array_like, shape (m, n) or (n,)
        Numbers (any unit); a vector becomes a column.
    decimals : int
        Decimal places shown; values that round to zero print as ``0.0...``
        (no ``-0.0``).

    Returns
    -------
    str
        ``\\begin{bmatrix} ... \\end{bmatrix}`` with ``&`` between columns.

    Raises
    ------
    ValueError
        ``a`` has more than two dimensions.

    Examples
    --------
    >>> matrix_latex([[1, 0], [0, 1]], decimals=1)
    '\\\\begin{bmatrix} 1.0 & 0.0 \\\\\\\\ 0.0 & 1.0 \\\\end{bmatrix}'
    """
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ShapeError(f"expected a matrix with shape (m, n) or (n,), got {a.shape}")
    fmt = f"{{:.{decimals}f}}"
    rows = [" & ".join(fmt.format(0.0 if abs(v) < 0.5 * 10 ** -decimals else v) for v in row) for row in a]
    return "\\begin{bmatrix} " + " \\\\ ".join(rows) + " \\end{bmatrix}"


def show_latex(expr, prefix="", decimals=4):
    """Display ``expr`` as display math.

    Parameters
    ----------
    expr : sympy expression/matrix, numpy array, or str
        A LaTeX string is shown as is; a numpy array via :func:`matrix_latex`.
    prefix : str
        LaTeX put before the expression, e.g. ``"{}^0_6T = "``.
    decimals : int
        Decimals for numeric arrays.

    Returns
    -------
    None
        (Outside IPython the LaTeX is printed instead.)
    """
    if isinstance(expr, str):
        tex = expr
    elif isinstance(expr, (np.ndarray, list, tuple)):
        tex = matrix_latex(expr, decimals)
    else:
        import sympy

        tex = sympy.latex(expr)
    tex = prefix + tex
    with needs_extra("reports"):
        from IPython.display import Math

    if not _display(Math(tex)):
        print(tex)


@dataclass(frozen=True)
class Comparison:
    """One reproduced-vs-published comparison.

    A check must agree within ``tol``; a ``typo`` row records a published value that is
    wrong (documented, never failing). ``error`` is the largest absolute difference.
    """

    name: str
    value: np.ndarray
    published: np.ndarray
    tol: float
    error: float
    passed: bool
    note: str = ""
    typo: bool = False
    relative: bool = False

    def shortfall(self) -> str:
        """The comparison in one line, its difference and tolerance as the check table prints them.

        Returns
        -------
        str
            ``"name: max |diff| 0.100 > tol 0.050"`` (what a failed check says).
        """
        cells = _row_cells(self)
        return f"{self.name}: max |diff| {cells['max |diff|']} > tol {cells['tolerance']}"


def _roundoff(a, tol=None, scale=None):
    """Threshold below which a number is round-off: min(tol, 1e-9 * scale), scale >= 1."""
    scale = max(1.0, float(scale) if scale is not None and np.isfinite(scale) else 1.0)
    return min(float(tol), 1e-9 * scale) if tol is not None and tol > 0 else 1e-12 * scale


#: significant digits of a check's numbers, of its difference and of its tolerance
_DIGITS = {"value": 6, "error": 3, "tol": 2}
#: no tolerance is round-off: the smallest positive float as the zero of its cell
_TINY = float(np.finfo(float).tiny)
#: a vector's items a check row shows (the rest as "...")
_SHOWN = 8


def _whole(a):
    """``a`` as integers when every number in it is whole (a count, a flag as 1.0), else unchanged."""
    a = np.asarray(a)
    if a.dtype.kind == "f" and a.size and np.all(np.isfinite(a)) and np.all(a == np.round(a)):
        a = a.astype(np.int64)
    return a[()] if a.ndim == 0 else a


def _fmt(a, zero=1e-12, like=None):
    """A check's number or numbers (at most :data:`_SHOWN` of them) as :func:`labkit.tables.format_value`
    prints them: six significant digits on the largest magnitude of ``a`` and ``like`` together."""
    a = np.asarray(a)
    flat = a.ravel()
    beside = flat if like is None else np.concatenate([flat, np.asarray(like).ravel()])
    if a.ndim == 0 or a.size == 1:
        return format_value(flat[0] if a.size else a, digits=_DIGITS["value"], zero=zero, like=beside)
    text = format_value(flat[:_SHOWN], digits=_DIGITS["value"], zero=zero, like=beside)
    return text[:-1] + ", ...)" if a.size > _SHOWN else text


#: MIME type of the rows a :meth:`Checks.assert_all` table carries for ``labkit report``
CHECKS_MIME = "application/vnd.labkit.checks+json"


def _row_cells(r) -> dict:
    """The displayed cells of one comparison, printed by :func:`labkit.tables.format_value`.

    Reproduced and published share their decimals (six significant digits on the row's largest
    magnitude), numbers that are all whole print as integers, round-off (below the tolerance and
    1e-9 of the published magnitude) as 0, a missing difference as a dash, a typo's tolerance as "typo".
    """
    published = np.asarray(r.published, dtype=float)
    scale = float(np.max(np.abs(published))) if published.size and np.all(np.isfinite(published)) else 1.0
    zero = _roundoff(None, None, scale)
    if not r.typo:
        zero = _roundoff(None, r.tol, scale)
        tol = format_value(_whole(r.tol), digits=_DIGITS["tol"], zero=_TINY) + (" (rel.)" if getattr(r, "relative", False) else "")
        result = "pass" if r.passed else "FAIL"
    else:
        tol, result = "typo", "published typo"
    value = np.asarray(r.value, dtype=float)
    whole = value.shape == published.shape and _whole(np.concatenate([value.ravel(), published.ravel()])).dtype.kind == "i"
    shown_value, shown_published = (_whole(value), _whole(published)) if whole else (value, published)
    return {"quantity": r.name, "reproduced": _fmt(shown_value, zero, like=shown_published),
            "published / expected": _fmt(shown_published, zero, like=shown_value),
            "max |diff|": format_value(_whole(r.error) if whole else r.error, digits=_DIGITS["error"], zero=zero),
            "tolerance": tol, "result": result, "note": r.note}


def _row_line(r) -> str:
    """One check as a line of text (a terminal, or the immediate :func:`check`)."""
    cells = _row_cells(r)
    return (f"{'PASS' if r.passed else 'FAIL'}  {r.name}: reproduced {cells['reproduced']}, published "
            f"{cells['published / expected']}, max |diff| {cells['max |diff|']} <= {cells['tolerance']}? {r.note}")


@dataclass
class Checks:
    """Collects the closing assertions of a notebook.

    Parameters
    ----------
    title : str
        Table caption.
    display : bool
        Show the rows: outside a notebook each row is printed as it is added; in a notebook
        they are shown once, as :meth:`assert_all`'s table (False in doctests/tests).
    """

    title: str = "Reproduced vs published"
    display: bool = True
    rows: list = field(default_factory=list)

    def check(self, name, value, published, tol, note="", *, relative=False) -> Comparison:
        """Compare ``value`` with ``published`` element-wise: ``max |value - published| <= tol``.

        The row is recorded (and printed when ``display``) whether it passes or not.

        Parameters
        ----------
        name : str
            What is compared (e.g. ``"T06 (sec. 2.2)"``).
        value, published : array_like, same shape
            Reproduced and published numbers (same units).
        tol : float
            Documented tolerance (absolute, or relative to ``|published|`` when ``relative``);
            typically half a unit of the last published digit.
        note : str
            Why this tolerance / what the source is.
        relative : bool
            Compare ``|value - published| / |published|`` with ``tol`` instead.

        Returns
        -------
        Comparison
            The recorded row (``passed`` says the outcome).

        Raises
        ------
        ValueError
            ``value`` and ``published`` differ in shape.
        """
        value = np.asarray(value, dtype=float)
        published = np.asarray(published, dtype=float)
        if value.shape != published.shape:
            raise ShapeError(f"{name}: expected the published shape {published.shape}, got {value.shape}")
        diff = np.abs(value - published)
        if relative:
            diff = diff / np.maximum(np.abs(published), np.finfo(float).tiny)
        err = float(np.max(diff)) if diff.size else 0.0
        row = Comparison(name, value, published, float(tol), err, bool(np.isfinite(err) and err <= tol), note,
                         relative=bool(relative))
        self.rows.append(row)
        if self.display and not _in_ipython():  # a notebook shows the rows once, in assert_all's table
            print(_row_line(row))
        return row

    def typo(self, name, published, correct, note) -> Comparison:
        """Record a published number that is wrong, with the corrected value and an explanation.

        Parameters
        ----------
        name : str
            What is corrected (e.g. ``"T06 (sec. 2.2)"``).
        published : array_like
            The number(s) as published.
        correct : array_like
            The corrected number(s), same units.
        note : str
            Why the published value is wrong.

        Returns
        -------
        Comparison
            The recorded row (``typo=True``, never failing; ``error`` is NaN if the
            shapes differ).
        """
        published = np.asarray(published, dtype=float)
        correct = np.asarray(correct, dtype=float)
        err = float(np.max(np.abs(correct - published))) if published.shape == correct.shape else float("nan")
        row = Comparison(name, correct, published, 0.0, err, True, note, typo=True)
        self.rows.append(row)
        if self.display and not _in_ipython():
            print(f"TYPO  {name}: published {_fmt(published)}, correct {_fmt(correct)}. {note}")
        return row

    def to_dataframe(self):
        """The rows as a pandas DataFrame (one row per check/typo).

        Returns
        -------
        pandas.DataFrame
            Columns ``quantity``, ``reproduced``, ``published / expected``,
            ``max |diff|``, ``tolerance``, ``result`` and ``note``, as display text printed by
            :func:`labkit.tables.format_value`: reproduced and published with the same decimals
            (six significant digits on the row's largest magnitude; integers when all are whole),
            the difference to three and the tolerance to two, round-off (below the tolerance and
            1e-9 of the published magnitude) as ``0``, and ``"typo"`` as the tolerance of a
            published typo.
        """
        import pandas as pd

        return pd.DataFrame([_row_cells(r) for r in self.rows],
                            columns=["quantity", "reproduced", "published / expected", "max |diff|", "tolerance",
                                     "result", "note"])

    @property
    def failures(self):
        """The rows that failed."""
        return [r for r in self.rows if not r.passed]

    def assert_all(self):
        """Show the table (in a notebook); raise :class:`~labkit.exceptions.CheckFailed` if any check failed."""
        if self.display and self.rows:
            df = self.to_dataframe()
            table = report_table(df, caption=self.title)  # the cells are text already: printed as they are
            bundle = {"text/html": table.to_html(), "text/plain": table.to_text(),
                      CHECKS_MIME: {"title": self.title, "rows": df.to_dict(orient="records")}}
            if not _display_raw(bundle):
                print(table.to_text())
        if self.failures:
            raise CheckFailed("reproduced numbers disagree with the published ones: " + "; ".join(
                r.shortfall() for r in self.failures))


def check(name, value, published, tol, note="", *, relative=False) -> Comparison:
    """One immediate check: print a pass/fail row and raise ``AssertionError`` on failure.

    Parameters
    ----------
    name : str
        What is compared.
    value, published : array_like, same shape
        Reproduced and published numbers (same units).
    tol : float
        Tolerance (absolute, or relative to ``|published|`` when ``relative``).
    note : str
        Why this tolerance / what the source is.
    relative : bool
        Use a relative tolerance.

    Returns
    -------
    Comparison
        The passing row.

    Raises
    ------
    AssertionError
        The check fails.
    ValueError
        ``value`` and ``published`` differ in shape.

    Examples
    --------
    >>> check("pi", 3.14159, 3.1416, tol=5e-5, note="4 decimals")  # doctest: +ELLIPSIS
    PASS  pi: ...
    Comparison(...)
    """
    row = Checks(display=False).check(name, value, published, tol, note, relative=relative)
    print(_row_line(row))
    cells = _row_cells(row)
    if not row.passed:
        raise CheckFailed(f"{name}: reproduced {cells['reproduced']} differs from published "
                          f"{cells['published / expected']} by {cells['max |diff|']} > tolerance {cells['tolerance']}")
    return row
