"""Tidy measurement logs: schema, crash-safe writer and validating CSV loader.

One row per reading (see ``docs/measurements.md``). :class:`MeasurementLog`
appends records to a CSV file; every :meth:`MeasurementLog.record` call
returns only after its line is written, flushed and ``fsync``-ed, so a record
that was acknowledged survives a crash or a ``SIGKILL``. The file is opened in
append mode and never truncated or rewritten: a crash leaves at most one
partial last line, which the next writer terminates (it never glues a new
record onto it) and which :func:`load_measurements` detects by its checksum
and skips with a warning.

Examples
--------
>>> import tempfile, pathlib
>>> from labkit.measure import MeasurementLog, load_measurements
>>> path = pathlib.Path(tempfile.mkdtemp()) / "fk_joint1.csv"
>>> with MeasurementLog("arduino_arm_3dof", path, operator="AB") as log:
...     rec = log.record("j1_45", "x", 18.2, unit="cm", instrument="ruler",
...                      resolution=0.05, commanded=[0.785398, 0.0, 0.0])
>>> rec.repeat, rec.record
(1, 1)
>>> df = load_measurements(path)
>>> row = df.iloc[0]
>>> row["pose_id"], row["quantity"], float(row["value"]), row["unit"]
('j1_45', 'x', 18.2, 'cm')
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import re
import zlib

from labkit.exceptions import MeasurementError, MeasurementWarning
from labkit.validation import as_batch, as_path

try:  # advisory lock against a second writer (POSIX only)
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = [
    "COLUMNS",
    "REQUIRED_COLUMNS",
    "UNITS",
    "MeasurementRecord",
    "MeasurementWarning",
    "quantity_dimension",
    "to_si",
    "parse_numbers",
]

#: Column order of a measurement CSV file written by :class:`MeasurementLog`.
COLUMNS = (
    "record", "session", "timestamp", "robot", "pose_id", "commanded", "target",
    "quantity", "repeat", "value", "unit", "instrument", "resolution",
    "half_range", "n_readings", "operator", "note", "check",
)
#: Columns a file must have; the others may be absent (hand-made files).
REQUIRED_COLUMNS = ("pose_id", "quantity", "value", "unit", "resolution")

#: Known units: name -> (dimension, factor to SI).
UNITS = {
    "m": ("length", 1.0),
    "cm": ("length", 0.01),
    "mm": ("length", 0.001),
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
}

_QUANTITY_PATTERNS = (
    (re.compile(r"^[xyz]$"), "length"),
    (re.compile(r"^theta[1-9][0-9]?$"), "angle"),
    (re.compile(r"^d[1-9][0-9]?$"), "length"),
)
_QUANTITY_HELP = "x, y, z (tool point [length]), theta<i> (joint i [angle]), d<i> (prismatic joint i [length])"


def quantity_dimension(quantity):
    """Dimension ("length" or "angle") of a measured quantity name.

    Parameters
    ----------
    quantity : str
        ``"x"``, ``"y"``, ``"z"`` (tool point), ``"theta<i>"`` (revolute joint
        i, 1-based) or ``"d<i>"`` (prismatic joint i).

    Returns
    -------
    {"length", "angle"}

    Raises
    ------
    MeasurementError
        For an unknown name (the message lists the valid ones).

    Examples
    --------
    >>> quantity_dimension("theta2")
    'angle'
    """
    q = str(quantity)
    for pattern, dim in _QUANTITY_PATTERNS:
        if pattern.match(q):
            return dim
    raise MeasurementError(f"unknown quantity {quantity!r}; expected one of {_QUANTITY_HELP}")


def to_si(value, unit):
    """Convert ``value`` given in ``unit`` to SI (m or rad).

    Parameters
    ----------
    value : float or array_like
        Value(s) in ``unit``.
    unit : {"m", "cm", "mm", "rad", "deg"}

    Returns
    -------
    float or ndarray
        ``value`` in m or rad (an array for array input, same shape).

    Raises
    ------
    MeasurementError
        For an unknown unit (the message lists the valid ones).

    Examples
    --------
    >>> to_si(180.0, "deg")
    3.141592653589793
    """
    factor = _unit(unit)[1]
    value = as_batch(value, (), "value", finite=False)  # NaN stays NaN: a missing reading
    return value * factor if value.ndim else float(value) * factor


def _unit(unit, **where):
    """``UNITS[unit]`` (its dimension and SI factor); an unknown unit is a MeasurementError listing the valid ones."""
    if not isinstance(unit, str) or unit not in UNITS:
        raise MeasurementError(f"unknown unit {unit!r}; expected one of {sorted(UNITS)}", **where)
    return UNITS[unit]


def _path(path, what):
    """``path`` as a :class:`pathlib.Path`; anything but a str or os.PathLike is a MeasurementError."""
    return as_path(path, what, error=MeasurementError)


def parse_numbers(text):
    """Parse a space-separated list of numbers (``commanded``/``target`` cells).

    Commas count as separators too.

    Parameters
    ----------
    text : str or None
        Cell text, e.g. ``"0.1 0 -0.05"``.

    Returns
    -------
    tuple of float or None
        ``None`` for an empty cell (or ``None``), else the numbers.

    Raises
    ------
    MeasurementError
        A token is not a number, or a number is not finite (also a ``ValueError``).

    Examples
    --------
    >>> parse_numbers("0.1 0 -0.05")
    (0.1, 0.0, -0.05)
    """
    if text is None:
        return None
    text = str(text).strip()
    if not text:
        return None
    values = []
    for token in text.replace(",", " ").split():
        try:
            value = float(token)
        except ValueError:
            raise MeasurementError(f"expected space-separated numbers, got {token!r} in {text!r}") from None
        if not math.isfinite(value):
            raise MeasurementError(f"expected finite numbers, got {token!r} in {text!r}")
        values.append(value)
    values = tuple(values)
    return values


def _format_numbers(values):
    if values is None:
        return ""
    return " ".join(repr(float(v)) for v in values)


def _checksum(body):
    return format(zlib.crc32(body.encode("utf-8")) & 0xFFFFFFFF, "08x")


@dataclasses.dataclass(frozen=True)
class MeasurementRecord:
    """One reading as written to a measurement log.

    Attributes
    ----------
    record : int
        1-based record number within the file (continues on resume).
    session, timestamp, robot, pose_id, quantity, unit, instrument, operator, note : str
        ``timestamp`` is ISO 8601 UTC (``2026-11-22T13:50:01.123456Z``).
    commanded : tuple of float or None
        Commanded joint values [rad, m].
    target : tuple of float or None
        Commanded Cartesian target [m] ((x, y, z) or (x, y, phi [rad]) ...).
    repeat : int
        1-based repeat index of this (session, pose_id, quantity).
    value, resolution : float
        Reading and instrument resolution, both in ``unit``.
    half_range : float
        Half the range of the readings summarised by a summary row (NaN for a raw reading).
    n_readings : int
        Number of readings a summary row stands for (1 for a raw reading).
    """

    record: int
    session: str
    timestamp: str
    robot: str
    pose_id: str
    commanded: tuple | None
    target: tuple | None
    quantity: str
    repeat: int
    value: float
    unit: str
    instrument: str
    resolution: float
    half_range: float = float("nan")
    n_readings: int = 1
    operator: str = ""
    note: str = ""

    def to_row(self):
        """The CSV fields (without the checksum), in :data:`COLUMNS` order.

        Returns
        -------
        list of str
            One string per column; numbers in ``repr`` form (round-trip exact),
            ``commanded``/``target`` space-separated, an unknown half range blank.
        """
        return [
            str(self.record), self.session, self.timestamp, self.robot, self.pose_id,
            _format_numbers(self.commanded), _format_numbers(self.target), self.quantity,
            str(self.repeat), repr(float(self.value)), self.unit, self.instrument,
            repr(float(self.resolution)),
            "" if math.isnan(self.half_range) else repr(float(self.half_range)),
            str(self.n_readings), self.operator, self.note,
        ]


def _one_line(text):
    return " ".join(str(text).splitlines()).replace("\r", " ")


def _encode_line(fields):
    buf = io.StringIO()
    csv.writer(buf, lineterminator="").writerow(fields)
    body = buf.getvalue()
    return f"{body},{_checksum(body)}\n"


_HEADER_LINE = ",".join(COLUMNS) + "\n"


