"""A measured-versus-calculated error table as a journal prints it (:func:`error_report_table`).

The layout of ``labkit.measure.ErrorTable`` in a report and in a notebook alike:
``ErrorTable.to_html`` / ``to_latex`` / ``style`` print this table, with the cells out of
tolerance marked, so a notebook and the lab report show the same numbers under the same headers.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.tables._table import HIGHLIGHT, ReportTable, report_table
from labkit.validation import as_number

__all__ = ["error_report_table"]

#: the columns of a measured-versus-calculated error table (``labkit.measure.ErrorTable.table``) a reader needs
_ERROR_COLUMNS = {"calculated": "calculated", "mean": "measured", "half_range": "±", "error": "error"}
#: the printed columns a mark (``flagged``) highlights: the reading and how far it is off
_FLAGGED_COLUMNS = ("measured", "error")


def error_report_table(errors, *, unit=None, scale=1.0, pose="command", digits=None, caption="", flagged=None,
                       highlight=HIGHLIGHT) -> ReportTable:
    """A measured-versus-calculated error table as a journal prints it: one row per pose and quantity.

    Columns: the pose, the quantity, calculated, measured (mean of the readings), ± (half
    their range), error (measured - calculated), each with its unit, and "within U" (yes/no:
    the error inside the measurement uncertainty). The rows of one pose form a group. The
    other columns of the error table (counts, spread, resolution, relative error) stay in
    its CSV; its summary (RMS, largest error) is a table of its own. Readings in several
    units (and no ``unit`` asked) name their unit beside the quantity ("x [m]").

    Parameters
    ----------
    errors : labkit.measure.ErrorTable or pandas.DataFrame
        The error table (or its long ``table``: columns ``pose_id, quantity, command, unit,
        calculated, mean, half_range, error, inside``).
    unit : str, optional
        The unit the numbers print in after ``scale`` ("mm"); default: the readings' unit.
    scale : float
        Factor from the readings' unit to ``unit`` (1e3 for m -> mm).
    pose : {"command", "pose_id"}
        What names a pose: the commanded joints or target ("q = (5, 0, 0) deg") or its id.
    digits : int or dict of str to int, optional
        Significant digits of each column's largest magnitude; per column by the names
        "calculated", "measured", "±", "error", with ``"*"`` for the rest. Default: 2 for
        ±, 3 for the error, and calculated and measured with the error's decimals (so that
        the printed error is the printed measured minus calculated).
    caption : str
        What the table shows.
    flagged : array_like of bool, shape (n_rows,), optional
        One flag per row of the error table: the measured and error cells of a flagged row
        are marked with ``highlight`` (``ErrorTable.to_html`` flags the readings out of
        tolerance). Default: nothing marked.
    highlight : str
        CSS of a marked cell.

    Returns
    -------
    ReportTable

    Raises
    ------
    OptionError
        ``pose`` is not "command" or "pose_id"; ``scale`` is not a positive number; the
        readings are in several units and ``unit`` / ``scale`` would print them as one.
    ShapeError
        ``errors`` lacks a column the layout needs; ``flagged`` is not one flag per row.

    Examples
    --------
    >>> import pandas as pd
    >>> long = pd.DataFrame({"pose_id": ["p1", "p1"], "quantity": ["x", "y"], "command": ["q = (5, 0) deg"] * 2,
    ...                      "unit": ["m", "m"], "calculated": [0.2733, 0.0239], "mean": [0.26, 0.065],
    ...                      "half_range": [0.02, 0.05], "error": [-0.0133, 0.0411], "inside": [True, True]})
    >>> print(error_report_table(long, unit="mm", scale=1e3).to_text())
    pose            quantity  calculated [mm]  measured [mm]  ± [mm]  error [mm]  within U
    q = (5, 0) deg  x                   273.3          260.0      20       -13.3  yes
                    y                    23.9           65.0      50        41.1  yes
    >>> error_report_table(long, flagged=[False, True]).marks[0][:2]  # row 1, measured
    (1, 3)
    """
    import pandas as pd

    if pose not in ("command", "pose_id"):
        raise OptionError(f"pose expects 'command' or 'pose_id', got {pose!r}")
    scale = as_number(scale, "scale", positive=True, error=OptionError)
    if unit is not None and not isinstance(unit, str):
        raise OptionError(f"unit expects the printed unit as a string ('mm'), got {unit!r}")
    table = getattr(errors, "table", errors)
    if not isinstance(table, pd.DataFrame):
        raise ShapeError(f"expected an ErrorTable or its DataFrame, got {type(errors).__name__}")
    needed = [pose, "quantity", "unit", *_ERROR_COLUMNS, "inside"]
    lacking = [c for c in needed if c not in table.columns]
    if lacking:
        raise ShapeError(f"expected an error table with columns {', '.join(needed)}; it lacks {', '.join(lacking)}")
    units = list(dict.fromkeys(table["unit"]))
    if len(units) > 1 and (unit is not None or scale != 1.0):
        raise OptionError(f"unit and scale convert readings of one unit; these are in {', '.join(units)}")
    shown = unit if unit is not None else (units[0] if len(units) == 1 else "")
    suffix = f" [{shown}]" if shown else ""
    quantity = table["quantity"].astype(str)
    if len(units) > 1:  # no one unit in the header: each quantity says its own
        quantity = quantity + " [" + table["unit"].astype(str) + "]"
    frame = pd.DataFrame({"pose": table[pose].to_numpy(), "quantity": quantity.to_numpy(),
                          **{f"{name}{suffix}": table[column].to_numpy(float) * float(scale)
                             for column, name in _ERROR_COLUMNS.items()},
                          "within U": table["inside"].to_numpy(bool)})
    if digits is None:  # error = measured - calculated: the three print with the error's decimals (3 digits)
        digits = {"±": 2, "*": 3}
        err = np.abs(frame[f"error{suffix}"].to_numpy(float))
        if np.isfinite(err).any() and np.nanmax(err) > 0:
            decimals = 2 - math.floor(math.log10(np.nanmax(err)))
            for name in ("calculated", "measured"):
                big = np.nanmax(np.abs(frame[f"{name}{suffix}"].to_numpy(float)), initial=0.0)
                digits[name] = max(1, decimals + 1 + math.floor(math.log10(big))) if big > 0 else 3
    if isinstance(digits, dict):
        digits = {(f"{k}{suffix}" if k in _ERROR_COLUMNS.values() else k): v for k, v in digits.items()}
    printed = report_table(frame, digits=digits, caption=caption, group="pose")
    if flagged is None:
        return printed
    try:
        flags = np.asarray(flagged)
    except ValueError:  # ragged
        flags = np.asarray(None)
    if flags.shape != (len(table),) or flags.dtype != bool:
        raise ShapeError(f"expected flagged as one bool per row of the error table, shape ({len(table)},), "
                         f"got {flags.dtype} with shape {flags.shape}")
    return printed.mark(np.flatnonzero(flags), [f"{name}{suffix}" for name in _FLAGGED_COLUMNS], highlight)
