"""How one cell prints: the number rule every table and every printed value of labkit follows.

A column of numbers gets one number of decimals, chosen so that its largest magnitude shows
``digits`` significant digits (scientific notation below 1e-3 or from 1e6 on; integers stay
integers); round-off (a magnitude at most ``zero``) prints as 0, never ``-0.00`` or ``5.6e-17``;
booleans print as words, vectors as ``(x, y, z)``, missing values (``None``, ``NaN``, ``pd.NA``)
as a dash. :func:`format_value` prints one value (or a vector) the same way for prose. Text goes
into HTML through :func:`html.escape` and into LaTeX through :func:`latex_escape`; a cell's CSS
(a highlight) becomes LaTeX through :func:`css_to_latex`.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from labkit.exceptions import OptionError
from labkit.validation import as_count, as_number

__all__ = ["format_value", "latex_escape", "css_to_latex"]

#: what a true and a false value print as unless a table says otherwise
BOOLEANS = ("yes", "no")
#: what a missing value prints as unless a table says otherwise
MISSING = "–"


def latex_escape(text) -> str:
    r"""Text as LaTeX prints it: the special characters escaped, ``±`` and ``°`` in math mode.

    Parameters
    ----------
    text : object
        Printed with ``str``.

    Returns
    -------
    str

    Examples
    --------
    >>> latex_escape("x_1 & 50 % ± 2")
    'x\\_1 \\& 50 \\% $\\pm$ 2'
    """
    out = str(text)
    for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("$", r"\$"), ("#", r"\#"),
                 ("_", r"\_"), ("{", r"\{"), ("}", r"\}"), ("~", r"\textasciitilde{}"), ("^", r"\^{}"),
                 ("–", "--"), ("±", r"$\pm$"), ("°", r"$^\circ$")):
        out = out.replace(a, b)
    return out


def css_to_latex(css) -> str:
    r"""A cell's CSS as the LaTeX commands that open the cell (``colortbl``/``xcolor`` for colours).

    ``background-color`` becomes ``\cellcolor``, ``color`` ``\color`` (a ``#rrggbb`` or ``#rgb``
    colour as ``[HTML]{RRGGBB}``, a name as it is), ``font-weight: bold`` ``\bfseries`` and
    ``font-style: italic`` ``\itshape``; other properties have no LaTeX form and are left out.

    Parameters
    ----------
    css : str
        Declarations ``"property: value; ..."``.

    Returns
    -------
    str

    Raises
    ------
    OptionError
        ``css`` is not a string of ``property: value`` declarations.

    Examples
    --------
    >>> css_to_latex("background-color: #f8c4c4; font-weight: bold")
    '\\cellcolor[HTML]{F8C4C4}\\bfseries '
    """
    if not isinstance(css, str):
        raise OptionError(f"expected CSS as a string ('background-color: #f8c4c4'), got {type(css).__name__}")
    out = []
    for declaration in filter(None, (d.strip() for d in css.split(";"))):
        name, colon, value = (part.strip() for part in declaration.partition(":"))
        if not colon or not name or not value:
            raise OptionError(f"expected CSS declarations 'property: value', got {declaration!r} in {css!r}")
        name, value = name.lower(), value.lower()
        if name in ("background-color", "background", "color"):
            command = r"\color" if name == "color" else r"\cellcolor"
            if value.startswith("#") and len(value) in (4, 7):
                hexa = value[1:] if len(value) == 7 else "".join(c * 2 for c in value[1:])
                out.append(f"{command}[HTML]{{{hexa.upper()}}}")
            else:
                out.append(f"{command}{{{value}}}")
        elif name == "font-weight" and value in ("bold", "bolder", "700", "800", "900"):
            out.append(r"\bfseries")
        elif name == "font-style" and value in ("italic", "oblique"):
            out.append(r"\itshape")
    return "".join(out) + (" " if out else "")


def _is_missing(v) -> bool:
    """True for ``None``, ``NaN``, ``pd.NA`` and ``pd.NaT``."""
    if v is None:
        return True
    try:
        import pandas as pd

        if v is pd.NA or v is pd.NaT:
            return True
    except ImportError:  # pragma: no cover - pandas is a dependency of the table's callers
        pass
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isnan(float(v))


def _is_vector(v) -> bool:
    return isinstance(v, (tuple, list, np.ndarray)) and not isinstance(v, str)


def _is_number_text(text) -> bool:
    """True for text that reads as a finite number (``"0.024"``: kept as printed, aligned as a number)."""
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _items(v):
    return np.asarray(v, dtype=object).ravel() if _is_vector(v) else [v]


def _numbers_of(values, zero=0.0):
    """Every finite real number in a column (vectors flattened), as floats; round-off (``<= zero``) as 0."""
    out = []
    for v in values:
        for x in _items(v):
            if isinstance(x, (bool, np.bool_)) or _is_missing(x) or not isinstance(x, numbers.Real):
                continue
            if math.isfinite(float(x)):
                out.append(0.0 if abs(float(x)) <= zero else float(x))
    return out


def _column_style(values, digits, zero):
    """(decimals, scientific) for a column: ``digits`` significant digits on its largest magnitude."""
    nums = _numbers_of(values, zero)
    if all(float(x).is_integer() for x in nums) and all(
            isinstance(x, (numbers.Integral, np.integer)) for v in values if not _is_missing(v) for x in _items(v)
            if isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))):
        return 0, False
    big = max((abs(x) for x in nums), default=0.0)
    if big == 0.0:
        return 0, False  # a column of zeros (round-off) prints 0
    if big >= 1e6 or big < 1e-3:
        return digits - 1, True
    exponent = math.floor(math.log10(big))
    return max(digits - 1 - exponent, 0), False


def _number(x, decimals, scientific, zero) -> str:
    x = 0.0 if abs(float(x)) <= zero else float(x)
    if math.isinf(x):
        return "∞" if x > 0 else "-∞"
    if scientific:
        if x == 0.0:
            return "0"
        mant, exp = f"{x:.{decimals}e}".split("e")
        return f"{mant}e{int(exp)}"
    text = f"{x:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # -0.00 is round-off
    return text


def _cell_text(v, decimals, scientific, words=BOOLEANS, missing=MISSING, zero=1e-9) -> str:
    """One cell as printed, with its column's ``(decimals, scientific)`` from :func:`_column_style`."""
    if _is_missing(v):
        return missing
    if isinstance(v, (bool, np.bool_)):
        return words[0] if v else words[1]
    if _is_vector(v):
        items = np.asarray(v, dtype=object).ravel()
        return "(" + ", ".join(_cell_text(x, decimals, scientific, words, missing, zero) for x in items) + ")"
    if isinstance(v, (numbers.Integral, np.integer)):
        return str(int(v)) if decimals == 0 and not scientific else _number(v, decimals, scientific, zero)
    if isinstance(v, numbers.Real):
        return _number(v, decimals, scientific, zero)
    return str(v)


def format_value(value, *, digits=4, decimals=None, unit="", zero=1e-9, like=None) -> str:
    """A number or a vector as prose prints it, the way :func:`report_table` prints a cell.

    Parameters
    ----------
    value : float or array_like
        A number, or numbers (printed as ``(a, b, c)``; a matrix row by row).
    digits : int
        Significant digits of the largest magnitude; every number gets the same decimals.
    decimals : int, optional
        Fixed decimals instead of ``digits``.
    unit : str
        Appended after a space ("mm", "deg").
    zero : float
        Round-off: a magnitude at most this prints as 0.
    like : array_like, optional
        Numbers printed beside ``value`` (the published value beside a reproduced one, a
        vector's items left out): the decimals come from ``value`` and ``like`` together, as
        down one column, so the two read digit for digit.

    Returns
    -------
    str

    Raises
    ------
    OptionError
        ``digits`` or ``decimals`` is not a non-negative integer (``digits`` positive), ``zero`` not a
        positive number.

    Examples
    --------
    >>> format_value([0.523599, 0.149718, -5.6e-17], decimals=4, unit="rad")
    '(0.5236, 0.1497, 0.0000) rad'
    >>> format_value(1.1e-13, unit="mm")
    '0 mm'
    >>> format_value(94.0, digits=6, like=94.00012)
    '94.0000'
    """
    digits = as_count(digits, "digits", minimum=1)
    zero = as_number(zero, "zero", positive=True, error=OptionError)
    if decimals is not None:
        decimals = as_count(decimals, "decimals", minimum=0)
    arr = np.asarray(value, dtype=object)
    flat = list(arr.ravel()) if arr.ndim else [value]
    if decimals is None:
        beside = [] if like is None else list(np.asarray(like, dtype=object).ravel())
        dec, scientific = _column_style(flat + beside, digits, zero)
    else:
        dec, scientific = int(decimals), False
    if arr.ndim == 0:
        text = _cell_text(value, dec, scientific, zero=zero)
    elif arr.ndim == 1:
        text = _cell_text(list(arr), dec, scientific, zero=zero)
    else:
        text = "(" + ", ".join(_cell_text(list(row), dec, scientific, zero=zero)
                               for row in arr.reshape(-1, arr.shape[-1])) + ")"
    return f"{text} {unit}" if unit else text
