"""Published-table audit: recompute published "calculated" values and flag disagreements.

A lab report prints values "calculated" from the robot model (positions from
forward kinematics, joint angles from inverse kinematics) to some precision.
:func:`load_published` reads such a table keeping the printed text, and
:func:`audit_published` recomputes every value from the robot file (with the
same model as :func:`labkit.measure.error_table`) and flags those that
disagree beyond the precision they were stated at (half a unit in the last
stated digit). ``labkit audit`` is the command line of the same check.

The names are also importable from :mod:`labkit.measure`.

Examples
--------
>>> from labkit.data import measurement_file
>>> audit = audit_published("arduino_arm_3dof", measurement_file("seed000_published_calculated.csv"))
>>> len(audit.cells), len(audit.flagged)
(63, 6)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from labkit.exceptions import MeasurementError
from labkit.measure._calculated import _frame, _robot, _wrap_deg_or_rad, calculated_si
from labkit.measure._schema import UNITS, _path, _unit, parse_numbers, quantity_dimension
from labkit.tables import HIGHLIGHT, format_value, report_table

# labkit.measure re-exports this module's names, so its helpers are imported
# inside the functions (no import cycle whichever module is imported first).

__all__ = ["AuditResult", "audit_published", "load_published"]

_AUDIT_REQUIRED = ("pose_id", "quantity", "published", "unit")


def load_published(path):
    """Load a table of published calculated values, keeping the printed text.

    Columns: ``pose_id, quantity, published`` (as printed, e.g. ``0.060``),
    ``unit``, ``commanded`` [rad] and/or ``target`` [m], optional ``table``,
    ``precision`` (``"<k>sf"`` for k significant figures, a number for the
    unit of the last stated digit, blank for the printed decimals) and
    ``note``.

    Parameters
    ----------
    path : str or os.PathLike
        CSV file.

    Returns
    -------
    pandas.DataFrame
        Text columns as str, ``commanded``/``target`` as tuples (or None),
        ``line`` the file line.

    Raises
    ------
    MeasurementError
        A required column is missing, or ``commanded``/``target`` is not a
        list of numbers (naming the row and column).
    """
    import pandas as pd

    path = _path(path, "the published-values CSV")
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (OSError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise MeasurementError(f"expected a readable published-values CSV, got: {exc}", path=path) from None
    missing = [c for c in _AUDIT_REQUIRED if c not in df.columns]
    if missing:
        raise MeasurementError(f"{path}: expected the column(s) {missing}; found {list(df.columns)}", line=1, column=missing[0])
    df["line"] = np.arange(len(df)) + 2
    for col in ("commanded", "target"):
        if col not in df:
            df[col] = ""
        parsed = []
        for text, line in zip(df[col], df["line"]):
            try:
                parsed.append(parse_numbers(text))
            except ValueError:
                raise MeasurementError(f"{path}: expected space-separated numbers, got {text!r}", line=line, column=col) from None
        df[col] = pd.Series(parsed, dtype=object, index=df.index)
    return df


def _stated_unit(text, precision, line):
    """Unit of the last stated digit of a published value."""
    
    text = str(text).strip()
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(f"expected a number, got {text!r}", line=line, column="published") from None
    precision = str(precision or "").strip()
    if precision.endswith("sf") and value != 0:
        try:
            k = int(precision[:-2])
        except ValueError:
            raise MeasurementError(f"expected precision like '2sf', a number or blank, got {precision!r}", line=line, column="precision") from None
        return value, 10.0 ** (math.floor(math.log10(abs(value))) - k + 1)
    if precision and not precision.endswith("sf"):
        try:
            return value, float(precision)
        except ValueError:
            raise MeasurementError(f"expected precision like '2sf', a number or blank, got {precision!r}", line=line, column="precision") from None
    mantissa = text.lower().split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(text.lower().split("e")[1]) if "e" in text.lower() else 0
    return value, 10.0 ** (exponent - decimals)


@dataclasses.dataclass(frozen=True)
class AuditResult:
    """Published calculated values beside the model's.

    Attributes
    ----------
    cells : pandas.DataFrame
        One row per published value: ``table, pose_id, quantity, unit,
        published, recomputed, difference, tolerance, agrees`` where
        ``tolerance`` is half a unit in the last stated digit and
        ``agrees = |published - recomputed| <= tolerance``.
    """

    cells: object

    @property
    def flagged(self):
        """The cells that disagree with the model."""
        return self.cells[~self.cells["agrees"]].reset_index(drop=True)

    def flagged_rows(self):
        """``{(table, pose_id): [quantities]}`` of the rows with a disagreement.

        Returns
        -------
        dict of (str, str) to list of str
        """
        out = {}
        for _, r in self.flagged.iterrows():
            out.setdefault((r["table"], r["pose_id"]), []).append(r["quantity"])
        return out

    def to_dataframe(self):
        """The cell table (a copy).

        Returns
        -------
        pandas.DataFrame
            Copy of :attr:`cells`.
        """
        return self.cells.copy()

    def report_table(self, *, highlight=HIGHLIGHT, caption=""):
        """The cell table as a report prints it, the rows that disagree highlighted.

        Published values print as published (the text kept); the recomputed value, the
        difference and the tolerance print in the unit of their row by the rule of every
        labkit table (:func:`labkit.tables.format_value`: 4, 2 and 1 significant digits;
        the rows mix units, so each row has its own decimals); ``agrees`` as yes / no.

        Parameters
        ----------
        highlight : str
            CSS of a cell in a row that does not agree.
        caption : str
            What the table shows.

        Returns
        -------
        labkit.tables.ReportTable

        Raises
        ------
        OptionError
            ``highlight`` is not CSS text.
        """
        import pandas as pd

        frame = self.cells.copy()
        for column, digits in _AUDIT_DIGITS.items():
            frame[column] = pd.Series([format_value(v, digits=digits) for v in frame[column]], index=frame.index,
                                      dtype=object)
        return report_table(frame, caption=caption, index=False).mark(~self.cells["agrees"].to_numpy(bool),
                                                                      css=highlight)

    def style(self, highlight=HIGHLIGHT):
        """A pandas Styler of :meth:`report_table`: the same cells, disagreeing rows highlighted.

        Parameters
        ----------
        highlight : str
            CSS of a cell in a row that does not agree.

        Returns
        -------
        pandas.io.formats.style.Styler
        """
        return self.report_table(highlight=highlight).to_styler()


#: significant digits of the numbers an audit prints (the published value keeps its own text)
_AUDIT_DIGITS = {"recomputed": 4, "difference": 2, "tolerance": 1}


def audit_published(robot, published, *, branch=None):
    """Recompute published "calculated" values and flag disagreements.

    A published value stated to a given precision claims the model value
    rounds to it: it *agrees* when ``|published - recomputed|`` is at most half
    a unit in its last stated digit (``0.060`` at 2 s.f. claims 0.0595-0.0605;
    an angle published to the degree claims ±0.5 deg). Angle differences are
    wrapped to (-180, 180] deg.

    Parameters
    ----------
    robot : Robot or str or None
        The model (or its name or file); ``None``: the one named in the
        table's ``robot`` column.
    published : pandas.DataFrame or str or os.PathLike
        Table as returned by :func:`load_published` (or its path).
    branch : str, optional
        IK branch for target rows; default the first branch that reaches
        each target (:func:`labkit.kinematics.ik`).

    Returns
    -------
    AuditResult

    Examples
    --------
    >>> from labkit.data import measurement_file
    >>> audit = audit_published("arduino_arm_3dof", measurement_file("seed000_published_calculated.csv"),
    ...                         branch="elbow_up")
    >>> sorted(audit.flagged_rows())[0]
    ('table 3', 't3_j3_20deg')
    """
    import pandas as pd

    df = _frame(published, load_published, _AUDIT_REQUIRED)
    robot = _robot(robot, df)
    for u, line in zip(df["unit"], df["line"]):
        _unit(u, line=line, column="unit")
    calc = calculated_si(df, robot, branch=branch)
    rows = []
    for k, r in enumerate(df.itertuples(index=False)):
        value, ulp = _stated_unit(r.published, getattr(r, "precision", ""), r.line)
        recomputed = calc[k] / UNITS[r.unit][1]
        diff = value - recomputed
        if quantity_dimension(r.quantity) == "angle":
            diff = float(_wrap_deg_or_rad(diff, r.unit))
        tol = ulp / 2
        rows.append(dict(table=getattr(r, "table", ""), pose_id=r.pose_id, quantity=r.quantity,
                         unit=r.unit, published=r.published, recomputed=recomputed,
                         difference=diff, tolerance=tol, agrees=bool(abs(diff) <= tol * (1 + 1e-9))))
    return AuditResult(cells=pd.DataFrame(rows))


# -- command line (called by labkit.measure.add_cli) ----------------------------
