"""The crash-safe measurement log (:class:`MeasurementLog`): every record is
written, flushed and ``fsync``-ed before :meth:`MeasurementLog.record` returns."""

from __future__ import annotations

import csv
import dataclasses
import errno
import os
import secrets
import threading
import warnings
from datetime import datetime, timezone

import numpy as np

from labkit.exceptions import MeasurementError, ShapeError, StorageError
from labkit.validation import as_number
from labkit.measure._schema import _path, COLUMNS, MeasurementRecord, MeasurementWarning, _HEADER_LINE, _encode_line, _one_line
from labkit.measure._csv import _check_quantity_unit, _check_ranges, _line_state, _read_rows, load_measurements

try:  # advisory lock against a second writer (POSIX only)
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = ["MeasurementLog"]


def _is_record(header, text):
    """Whether ``text`` (a line without its newline) loads as a record under ``header``: whole and checked."""
    try:
        fields = next(csv.reader([text], strict=True))
    except (csv.Error, StopIteration):
        return False
    return _line_state(header, fields, text) == "ok" and (
        "check" not in header or len(fields[header.index("check")].strip()) == 8)


def _torn_terminator(header, text):
    """What to append to the torn line ``text`` so that no reader loads it: ``""`` or an unclosed quote.

    A cut inside a field leaves too few fields (or a cut checksum): a newline is enough. A cut right after the
    last comma would load as a record with a blank (hand-edited) check cell: an unclosed quote makes it torn.
    """
    for term in ("", '"', ',"'):
        try:
            fields = next(csv.reader([text + term], strict=True))
        except (csv.Error, StopIteration):
            return term
        if _line_state(header, fields, text + term) == "torn":
            return term
    return ',"'


class MeasurementLog:
    """Append-only, crash-safe measurement log (a CSV file).

    Parameters
    ----------
    robot : Robot or str or None
        Robot (or its name) the readings refer to; ``None``: the resumed
        session's robot, else "".
    path : str or os.PathLike
        CSV file; created (with its header) if missing, else resumed.
    session : str, optional
        Session id. Default: the last session in an existing file (resume),
        or a new id ``YYYYmmddTHHMMSSZ-xxxx`` for a new file.
    operator : str, optional
        Who takes the readings. Default: the resumed session's operator, else "".
    poses : mapping, optional
        ``pose_id -> {"commanded": q [rad, m], "target": x [m]}``. When given,
        :meth:`record` rejects unknown pose ids and fills in the pose's
        commanded joints / target.

    Notes
    -----
    The file is opened with ``O_APPEND`` and locked (``flock``) against a
    second writer; nothing already written is ever modified. A partial last
    line left by a crash is terminated with a newline before the first new
    record, so it stays a separate (skipped) torn line.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "log.csv"
    >>> log = MeasurementLog("arduino_arm_3dof", path, session="s1")
    >>> _ = log.record("p1", "theta1", 45.0, unit="deg", instrument="protractor", resolution=0.5)
    >>> log.close()
    >>> MeasurementLog(None, path).record("p1", "theta1", 46.0, unit="deg",
    ...                                   instrument="protractor", resolution=0.5).repeat
    2
    """

    def __init__(self, robot, path, *, session=None, operator=None, poses=None):
        self.path = _path(path, "the log")
        self._lock = threading.Lock()
        self.poses = None if poses is None else {str(k): dict(v) for k, v in poses.items()}
        if robot is not None and not isinstance(robot, str) and not hasattr(robot, "fk"):
            raise MeasurementError(f"expected robot as a Robot, a robot name or None, got {robot!r}")
        self._robot_obj = robot if hasattr(robot, "fk") else None
        raw = b""
        if self.path.exists():
            with open(self.path, "rb") as f:
                raw = f.read(len(_HEADER_LINE))
        torn_header = b"\n" not in raw and _HEADER_LINE.encode().startswith(raw)
        existing = []
        if raw and not torn_header:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MeasurementWarning)
                existing = _read_rows(self.path)
        created = not self.path.exists()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            if fcntl is not None:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise MeasurementError(f"{self.path} is already open by another MeasurementLog writer") from None
        self._fd = fd
        self._torn = False
        if created:
            _fsync_dir(self.path.parent)
        size = os.fstat(fd).st_size
        self._header = list(COLUMNS)
        self._failed = None  # (line, bytes of it on disk, record, key) of a write that raised StorageError
        if size == 0:
            self._write(_HEADER_LINE)
        else:
            with open(self.path, "rb") as f:
                first = f.readline().decode("utf-8", "replace").lstrip("\ufeff").strip()
                f.seek(size - 1)
                last_byte = f.read(1)
                if first and not torn_header:
                    self._header = [c.strip() for c in first.split(",")]
                if last_byte != b"\n":
                    f.seek(max(0, size - 65536))
                    tail = f.read().rsplit(b"\n", 1)[-1].decode("utf-8", "replace").rstrip("\r")
            if last_byte != b"\n":
                if torn_header:  # the crash cut the header itself
                    self._write("\n" + _HEADER_LINE)
                elif _is_record(self._header, tail):
                    self._write("\n")  # a whole, checked record that only lost its newline: kept
                else:  # a torn record from a crash: sealed so that no reader takes it for a record, and reported
                    self._write(_torn_terminator(self._header, tail) + "\n")
                    existing = [(n, row) for n, row in existing if n != existing[-1][0]] if existing and \
                        existing[-1][1].get("check", "x").strip() == "" else existing
                    warnings.warn(f"{self.path}: the last line was torn by a crash or a full disk "
                                  f"({len(tail)} bytes, not a whole checked record): skipped, never loaded",
                                  MeasurementWarning, stacklevel=2)
        self._next_record = 1
        self._repeats = {}
        existing = [(n, {k: (v or "").strip() for k, v in row.items()}) for n, row in existing]
        last = existing[-1][1] if existing else {}
        last_session = last.get("session")
        for lineno, row in existing:
            record, repeat = _int_or_none(row.get("record")), _int_or_none(row.get("repeat"))
            self._next_record = max(self._next_record, (record or 0) + 1)
            key = (row.get("session", ""), row.get("pose_id", ""), row.get("quantity", ""))
            self._repeats[key] = max(self._repeats.get(key, 0), repeat or 0)
        if existing and self._next_record == 1:
            self._next_record = len(existing) + 1
        last_robot, last_operator = last.get("robot", ""), last.get("operator", "")
        if session is None:
            session = last_session or (
                datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-" + secrets.token_hex(2)
            )
        self.session = _one_line(session)
        if robot is None:
            robot = last_robot if session == last_session else ""
        self.robot = _one_line(getattr(robot, "name", robot))
        if operator is None:
            operator = last_operator if session == last_session else ""
        self.operator = _one_line(operator)

    # -- writing ------------------------------------------------------------
    def _write(self, text):
        # after a failed write (disk full, I/O error) the file may end in a torn
        # line: start the next write on a fresh line so nothing is glued onto it
        data = (("\n" if self._torn else "") + text).encode("utf-8")
        view = memoryview(data)
        self._torn = True
        start = os.fstat(self._fd).st_size + len(data) - len(text.encode("utf-8"))
        try:
            while view:
                n = os.write(self._fd, view)
                view = view[n:]
            os.fsync(self._fd)
        except OSError as exc:
            try:  # bytes of `text` in the file (the file's size says it, whatever the failing call reported)
                self._landed = max(0, os.fstat(self._fd).st_size - start)
            except OSError:
                self._landed = len(text.encode("utf-8")) - 1  # unknown: its end gets a newline on retry
            hint = ("the disk is full: free some space" if exc.errno == errno.ENOSPC
                    else "check the disk or the file system")
            raise StorageError(f"cannot write the measurement log {self.path}: {exc.strerror or exc}; {hint}, "
                               f"then record again (every reading recorded before is safe on disk)") from exc
        self._torn = False

    def record(self, pose_id, quantity, value, *, unit, instrument, resolution,
               commanded=None, target=None, repeat=None, note="",
               half_range=None, n_readings=1):
        """Append one reading; returns after it is written, flushed and fsynced.

        Parameters
        ----------
        pose_id : str
            Pose (or target) identifier.
        quantity : str
            ``"x"``, ``"y"``, ``"z"``, ``"theta<i>"`` or ``"d<i>"``.
        value : float
            The reading, in ``unit``.
        unit : {"m", "cm", "mm", "rad", "deg"}
            Must match the dimension of ``quantity``.
        instrument : str
            E.g. ``"ruler"``, ``"protractor"``.
        resolution : float
            Instrument resolution in ``unit`` (> 0).
        commanded : array_like, shape (n,), optional
            Commanded joint values [rad, m].
        target : array_like, shape (k,), optional
            Commanded Cartesian target [m] (angles in rad).
        repeat : int, optional
            Repeat index; default: one more than the last of this
            (session, pose_id, quantity).
        note : str
            Operator note (newlines become spaces).
        half_range, n_readings : float, int, optional
            Only for a *summary* row that stands for ``n_readings`` readings
            with mean ``value`` and half range ``half_range`` (in ``unit``).

        Returns
        -------
        MeasurementRecord

        Raises
        ------
        MeasurementError
            Naming the column of a bad argument; nothing is written then.
        """
        with self._lock:
            return self._record(pose_id, quantity, value, unit=unit, instrument=instrument,
                                resolution=resolution, commanded=commanded, target=target,
                                repeat=repeat, note=note, half_range=half_range, n_readings=n_readings)

    def _record(self, pose_id, quantity, value, *, unit, instrument, resolution, commanded,
                target, repeat, note, half_range, n_readings):
        if self._fd is None:
            raise MeasurementError(f"{self.path}: the log is closed")
        pose_id = _one_line(pose_id).strip()
        if not pose_id:
            raise MeasurementError("expected a non-empty pose id", column="pose_id")
        if self.poses is not None:
            if pose_id not in self.poses:
                raise MeasurementError(f"unknown pose id {pose_id!r}; known: {sorted(self.poses)}", column="pose_id")
            pose = self.poses[pose_id]
            commanded = pose.get("commanded") if commanded is None else commanded
            target = pose.get("target") if target is None else target
        quantity = str(quantity)
        _check_quantity_unit(quantity, unit)
        value = _finite(value, "value")
        resolution = _finite(resolution, "resolution")
        hr = float("nan") if half_range is None else _finite(half_range, "half_range")
        _check_ranges(resolution, hr, n_readings)
        commanded = _vector(commanded, "commanded")
        target = _vector(target, "target")
        robot_n = getattr(self._robot_obj, "n", None)
        if commanded is not None and robot_n is not None and len(commanded) != robot_n:
            raise MeasurementError(f"expected {robot_n} commanded joint values, got {len(commanded)}", column="commanded")
        key = (self.session, pose_id, quantity)
        if repeat is not None:
            repeat = int(repeat)
            if repeat < 1:
                raise MeasurementError(f"expected a repeat index >= 1, got {repeat}", column="repeat")

        def build():
            return MeasurementRecord(
                record=self._next_record, session=self.session,
                timestamp=datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
                robot=self.robot, pose_id=pose_id, commanded=commanded, target=target,
                quantity=quantity, repeat=self._repeats.get(key, 0) + 1 if repeat is None else repeat,
                value=value, unit=unit, instrument=_one_line(instrument), resolution=resolution, half_range=hr,
                n_readings=int(n_readings), operator=self.operator, note=_one_line(note),
            )

        rec = build()
        if self._failed is not None:
            stored = self._settle_failed()
            if stored is not None and dataclasses.replace(rec, timestamp=stored.timestamp).to_row() == stored.to_row():
                return stored  # the retry of a reading that did reach the disk whole: not written twice
            rec = build()
        line = _encode_line(rec.to_row())
        try:
            self._write(line)
        except StorageError:
            self._failed = (line, self._landed, rec, key)
            raise
        self._next_record += 1
        self._repeats[key] = max(self._repeats.get(key, 0), rec.repeat)
        return rec

    def _settle_failed(self):
        """Make the line of the write that raised :class:`StorageError` whole or surely torn.

        Returns the failed record if all of it reached the disk (then it counts: its record number and
        repeat are used, its newline is added if missing), else None (its torn part is sealed so that no
        reader loads it, and its record number is free again).
        """
        line, landed, rec, key = self._failed
        data = line.encode("utf-8")
        self._torn = False  # the torn line is terminated here, not by a bare newline
        if landed >= len(data) - 1:  # the whole checked record, perhaps without its newline
            if landed < len(data):
                self._write("\n")
            self._failed = None
            self._next_record = max(self._next_record, rec.record + 1)
            self._repeats[key] = max(self._repeats.get(key, 0), rec.repeat)
            return rec
        if landed > 0:
            part = data[:landed].decode("utf-8", "ignore")
            self._write(_torn_terminator(self._header, part) + "\n")
        self._failed = None
        return None

    def to_dataframe(self, *, all_sessions=False):
        """The file's records as a DataFrame (this session's only by default).

        Parameters
        ----------
        all_sessions : bool
            Return the records of every session in the file.

        Returns
        -------
        pandas.DataFrame
            As :func:`load_measurements` returns it (index reset after filtering).
        """
        df = load_measurements(self.path)
        if not all_sessions:
            df = df[df["session"] == self.session].reset_index(drop=True)
        return df

    def close(self):
        """Release the lock and close the file (idempotent)."""
        fd, self._fd = getattr(self, "_fd", None), None
        if fd is not None:
            os.close(fd)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def __repr__(self):
        return f"MeasurementLog({self.robot!r}, {str(self.path)!r}, session={self.session!r})"


def _int_or_none(text):
    try:
        return int(float(text))
    except (TypeError, ValueError, OverflowError):
        return None


def _finite(value, column):
    try:
        return as_number(value, column)
    except ShapeError as exc:
        raise MeasurementError(str(exc), column=column) from None


def _vector(values, column):
    if values is None:
        return None
    try:
        arr = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise MeasurementError(f"expected numbers, got {values!r}", column=column) from None
    if not np.all(np.isfinite(arr)):
        raise MeasurementError(f"expected finite numbers, got {values!r}", column=column)
    return tuple(float(v) for v in arr)


def _fsync_dir(directory):
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)

