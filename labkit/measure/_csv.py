"""CSV loader of measurement logs (private; re-exported by :mod:`labkit.measure`).

:func:`load_measurements` reads a file written by
:class:`labkit.measure.MeasurementLog` (or made by hand), skips torn lines
left by a crash with a :class:`~labkit.measure.MeasurementWarning`, checks
the per-line checksums and validates every row (numbers, units, quantity
names, pose ids) against the schema of :mod:`labkit.measure`.
``_read_rows`` is the pandas-free part the writer uses to resume a file;
``_check_quantity_unit`` and ``_check_ranges`` are shared with the writer.
"""

from __future__ import annotations

import csv
import math
import warnings
from datetime import datetime
from pathlib import Path

from labkit.exceptions import MeasurementError
from labkit.measure._schema import (
    COLUMNS,
    REQUIRED_COLUMNS,
    UNITS,
    MeasurementWarning,
    _checksum,
    _path,
    _unit,
    parse_numbers,
    quantity_dimension,
)

__all__ = ["load_measurements"]


def _check_quantity_unit(quantity, unit, **where):
    try:
        dim = quantity_dimension(quantity)
    except MeasurementError as exc:
        raise MeasurementError(str(exc), column="quantity", **where) from None
    if _unit(unit, column="unit", **where)[0] != dim:
        raise MeasurementError(f"unit {unit!r} is a {UNITS[unit][0]} but quantity {quantity!r} is a {dim}",
                     column="unit", **where)


def _check_ranges(resolution, half_range, n_readings, **where):
    if not resolution > 0:
        raise MeasurementError(f"expected a positive resolution, got {resolution!r}", column="resolution", **where)
    if half_range < 0:
        raise MeasurementError(f"expected half_range >= 0, got {half_range!r}", column="half_range", **where)
    if not n_readings >= 1:
        raise MeasurementError(f"expected n_readings >= 1, got {n_readings!r}", column="n_readings", **where)


def load_measurements(path, *, poses=None, validate=True):
    """Load and validate a measurement CSV file.

    Parameters
    ----------
    path : str or os.PathLike
        A file written by :class:`MeasurementLog` or made by hand with at
        least the columns :data:`REQUIRED_COLUMNS`.
    poses : collection of str or mapping, optional
        Known pose ids; a row with another pose id is an error.
    validate : bool
        Check every row (numbers, units, quantity names). Only the writer's
        resume logic turns this off.

    Returns
    -------
    pandas.DataFrame
        One row per reading, columns :data:`COLUMNS` (minus ``check``) plus
        ``line`` (1-based line number in the file). ``commanded`` and
        ``target`` hold tuples of float (or None); ``timestamp`` is a UTC
        datetime (NaT when blank).

    Raises
    ------
    MeasurementError
        For a missing column, a non-numeric reading, an unknown unit or
        quantity, a unit that does not match the quantity, or an unknown pose
        id; the message names the row (file line) and the column.

    Warns
    -----
    MeasurementWarning
        When a torn line from a crash is skipped: a partial last line, or a
        line that is a prefix of a record (too few fields, or a cut
        checksum) which a resuming writer terminated. A complete line whose
        checksum does not match is an error (column ``check``), not skipped.
    """
    path = _path(path, "the measurement log")
    return _to_frame(path, _read_rows(path), poses, validate)


def _read_rows(path):
    """``[(line number, {column: text})]`` of the intact records (pure csv; no pandas)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MeasurementError(f"expected a readable measurement file, got {path}: {exc}") from None
    lines = raw.split(b"\n")
    complete_tail = raw.endswith(b"\n")
    if complete_tail:
        lines = lines[:-1]
    header = None
    rows = []
    for index, blob in enumerate(lines):
        lineno = index + 1
        is_last_partial = index == len(lines) - 1 and not complete_tail
        text = None
        try:
            text = blob.decode("utf-8").rstrip("\r")
        except UnicodeDecodeError:
            pass
        if header is None:
            if text is None or not text.strip():
                if text is not None:
                    continue
                raise MeasurementError("cannot decode the header as UTF-8", path=path, line=lineno)
            fields = [f.strip() for f in next(csv.reader([text.lstrip("\ufeff")]))]  # Excel writes a BOM
            if _is_torn_header(fields, lines, index):
                warnings.warn(f"{path}: row {lineno}: skipping a torn header line", MeasurementWarning, stacklevel=3)
                continue
            missing = [c for c in REQUIRED_COLUMNS if c not in fields]
            if missing:
                raise MeasurementError(f"expected the column(s) {missing}; found {fields}", path=path, line=lineno, column=missing[0])
            header = fields
            continue
        if text is not None and not text.strip():
            continue
        fields = None
        if text is not None:
            try:
                fields = next(csv.reader([text], strict=True))
            except (csv.Error, StopIteration):
                fields = None
        state = "torn" if fields is None else _line_state(header, fields, text)
        if state == "corrupt":
            raise MeasurementError("checksum does not match the line (edited or corrupted after logging; "
                         "blank the check cell to accept a hand edit)", path=path, line=lineno, column="check")
        if state == "extra":
            raise MeasurementError(f"expected {len(header)} fields, got {len(fields)}", path=path, line=lineno)
        if state == "torn":
            if is_last_partial or "check" in header:
                warnings.warn(
                    f"{path}: row {lineno}: skipping a torn record (partial line left by a crash)",
                    MeasurementWarning, stacklevel=3,
                )
                continue
            if fields is None:
                raise MeasurementError("cannot parse the line as CSV (unbalanced quotes, a line break inside a "
                             "cell, or not UTF-8)", path=path, line=lineno)
            raise MeasurementError(f"expected {len(header)} fields, got {len(fields)}", path=path, line=lineno)
        if is_last_partial and "check" not in header:
            warnings.warn(f"{path}: row {lineno}: last line has no newline (partial write?); kept",
                          MeasurementWarning, stacklevel=3)
        rows.append((lineno, dict(zip(header, fields))))
    if header is None:
        raise MeasurementError(f"no header line; expected columns {list(COLUMNS)}", path=path)
    return rows


def _is_torn_header(fields, lines, index):
    if fields == list(COLUMNS):
        return False
    joined = ",".join(fields)
    canonical = ",".join(COLUMNS)
    return canonical.startswith(joined) and index + 1 < len(lines)


def _line_state(header, fields, text):
    """"ok", "torn" (a prefix of a record: crash) or "corrupt" (full checksum that does not match)."""
    if len(fields) < len(header):
        return "torn"
    if len(fields) > len(header):
        return "extra"
    if "check" in header:
        check = fields[header.index("check")].strip()
        if check and header[-1] == "check":
            if len(check) < 8:
                return "torn"  # cut inside the checksum itself
            return "ok" if _checksum(text[: text.rfind(",")]) == check else "corrupt"
    return "ok"


def _to_frame(path, rows, poses, validate):
    import pandas as pd

    known = None if poses is None else {str(p) for p in poses}
    text_cols = ("session", "timestamp", "robot", "pose_id", "quantity", "unit", "instrument", "operator", "note")
    number_cols = ("record", "repeat", "value", "resolution", "half_range", "n_readings")
    data = {c: [] for c in COLUMNS if c != "check"}
    data["line"] = []
    for lineno, row in rows:
        where = dict(path=path, line=lineno)
        cells = {c: (row.get(c) or "").strip() for c in text_cols + number_cols + ("commanded", "target")}
        numbers = {}
        for col in number_cols:
            text = cells[col]
            required = validate and col in ("value", "resolution")
            if not text:
                if required:
                    raise MeasurementError("expected a number, got an empty cell", column=col, **where)
                numbers[col] = float("nan")
                continue
            try:
                v = float(text)
            except ValueError:
                raise MeasurementError(f"expected a number, got {text!r}", column=col, **where) from None
            if not math.isfinite(v) or (col in ("record", "repeat", "n_readings") and v != int(v)):
                kind = "a finite number" if col in ("value", "resolution", "half_range") else "an integer"
                raise MeasurementError(f"expected {kind}, got {text!r}", column=col, **where)
            numbers[col] = v
        if math.isnan(numbers["n_readings"]):
            numbers["n_readings"] = 1.0
        if validate:
            if not cells["pose_id"]:
                raise MeasurementError("expected a pose id, got an empty cell", column="pose_id", **where)
            if known is not None and cells["pose_id"] not in known:
                raise MeasurementError(f"unknown pose id {cells['pose_id']!r}; known: {sorted(known)}",
                             column="pose_id", **where)
            _check_quantity_unit(cells["quantity"], cells["unit"], **where)
            _check_ranges(numbers["resolution"], numbers["half_range"], numbers["n_readings"], **where)
            if cells["timestamp"]:
                try:
                    datetime.fromisoformat(cells["timestamp"].replace("Z", "+00:00"))
                except ValueError:
                    raise MeasurementError(f"expected an ISO 8601 timestamp, got {cells['timestamp']!r}",
                                 column="timestamp", **where) from None
        for col in ("commanded", "target"):
            try:
                cells[col] = parse_numbers(cells[col])
            except ValueError:
                raise MeasurementError(f"expected space-separated numbers, got {cells[col]!r}", column=col, **where) from None
        cells["timestamp"] = cells["timestamp"] or None
        for col in data:
            data[col].append(lineno if col == "line" else numbers[col] if col in numbers else cells[col])
    df = pd.DataFrame({k: v for k, v in data.items() if k not in ("commanded", "target")})
    df.insert(5, "commanded", pd.Series(data["commanded"], dtype=object))
    df.insert(6, "target", pd.Series(data["target"], dtype=object))
    for col in ("record", "repeat", "n_readings", "line"):
        df[col] = df[col].astype("Int64")
    for col in ("session", "robot", "pose_id", "quantity", "unit", "instrument", "operator", "note"):
        df[col] = df[col].astype("str")
    df["timestamp"] = pd.to_datetime(df["timestamp"], utc=True, format="ISO8601")
    return df


# The schema lives in labkit.measure, which re-exports load_measurements from here: import it
# last, so either module may be imported first (every name above is defined by then).
