"""Tests of labkit.measure measurement logs: schema, crash-safe writer, validating loader."""

import os
import signal
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pandas as pd
import pytest

from labkit.exceptions import MeasurementError
from labkit.measure import (
    COLUMNS,
    MeasurementLog,
    MeasurementWarning,
    load_measurements,
    quantity_dimension,
    to_si,
)


def _log_three(path, **kwargs):
    with MeasurementLog("arduino_arm_3dof", path, operator="AB", **kwargs) as log:
        recs = [
            log.record("j1_45", "x", v, unit="cm", instrument="ruler", resolution=0.05,
                       commanded=[np.pi / 4, 0.0, 0.0])
            for v in (18.1, 18.2, 18.3)
        ]
    return recs


def test_record_round_trip(tmp_path):
    path = tmp_path / "log.csv"
    recs = _log_three(path)
    assert [r.repeat for r in recs] == [1, 2, 3]
    assert [r.record for r in recs] == [1, 2, 3]
    df = load_measurements(path)
    assert list(df["value"]) == [18.1, 18.2, 18.3]
    assert df.loc[0, "commanded"] == (np.pi / 4, 0.0, 0.0)
    assert df.loc[0, "target"] is None
    assert set(df["robot"]) == {"arduino_arm_3dof"}
    assert str(df["timestamp"].dt.tz) == "UTC"
    assert list(df["line"]) == [2, 3, 4]
    header = path.read_text().splitlines()[0]
    assert header == ",".join(COLUMNS)


def test_resume_continues_numbering(tmp_path):
    path = tmp_path / "log.csv"
    first = _log_three(path)
    with MeasurementLog(None, path) as log:
        assert log.session == first[0].session
        assert log.robot == "arduino_arm_3dof"
        assert log.operator == "AB"
        rec = log.record("j1_45", "x", 18.4, unit="cm", instrument="ruler", resolution=0.05)
        other = log.record("j1_60", "x", 12.0, unit="cm", instrument="ruler", resolution=0.05)
    assert (rec.record, rec.repeat) == (4, 4)
    assert (other.record, other.repeat) == (5, 1)
    # a new session in the same file restarts repeats but not record numbers
    with MeasurementLog(None, path, session="second") as log:
        rec = log.record("j1_45", "x", 18.0, unit="cm", instrument="ruler", resolution=0.05)
    assert (rec.record, rec.repeat) == (6, 1)
    assert len(load_measurements(path)) == 6


def test_nothing_rewritten(tmp_path):
    path = tmp_path / "log.csv"
    _log_three(path)
    before = path.read_bytes()
    _log_three(path)
    assert path.read_bytes().startswith(before)


def test_torn_last_line_is_skipped_and_terminated(tmp_path):
    path = tmp_path / "log.csv"
    _log_three(path)
    full = path.read_bytes()
    with open(path, "ab") as f:  # simulate a crash in the middle of a line
        f.write(full.splitlines(keepends=True)[-1][:37])
    with pytest.warns(MeasurementWarning, match="row 5"):
        assert len(load_measurements(path)) == 3
    with MeasurementLog(None, path) as log:
        rec = log.record("j1_45", "x", 18.4, unit="cm", instrument="ruler", resolution=0.05)
    assert rec.record == 4
    with pytest.warns(MeasurementWarning, match="torn record"):
        df = load_measurements(path)
    assert list(df["value"]) == [18.1, 18.2, 18.3, 18.4]
    assert path.read_bytes().startswith(full)


def test_torn_line_cut_inside_quoted_note(tmp_path):
    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s") as log:
        log.record("p", "theta1", 45, unit="deg", instrument="protractor", resolution=0.5,
                   note='hard to read, "wobbly"\nsecond line')
    line = path.read_bytes().splitlines(keepends=True)[-1]
    with open(path, "ab") as f:
        f.write(line[: line.index(b"wobbly")])
    with MeasurementLog(None, path) as log:
        log.record("p", "theta1", 46, unit="deg", instrument="protractor", resolution=0.5)
    with pytest.warns(MeasurementWarning):
        df = load_measurements(path)
    assert list(df["value"]) == [45.0, 46.0]
    assert df.loc[0, "note"] == 'hard to read, "wobbly" second line'


def test_second_writer_is_refused(tmp_path):
    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s"):
        with pytest.raises(MeasurementError, match="already open"):
            MeasurementLog(None, path)


@pytest.mark.parametrize(
    "kwargs, column",
    [
        (dict(value="abc"), "value"),
        (dict(unit="furlong"), "unit"),
        (dict(unit="deg"), "unit"),
        (dict(quantity="w"), "quantity"),
        (dict(resolution=0.0), "resolution"),
        (dict(commanded=[0.0, float("nan"), 0.0]), "commanded"),
        (dict(pose_id="nowhere"), "pose_id"),
    ],
)
def test_record_rejects_bad_input_and_keeps_log(tmp_path, kwargs, column):
    path = tmp_path / "log.csv"
    _log_three(path)
    before = path.read_bytes()
    args = dict(pose_id="j1_45", quantity="x", value=1.0, unit="cm", instrument="ruler", resolution=0.05)
    args.update(kwargs)
    with MeasurementLog(None, path, poses={"j1_45": {"commanded": [0.7, 0, 0]}}) as log:
        with pytest.raises(MeasurementError, match=f"column '{column}'") as info:
            log.record(args.pop("pose_id"), args.pop("quantity"), args.pop("value"), **args)
    assert info.value.column == column
    assert path.read_bytes() == before
    assert len(load_measurements(path)) == 3


def test_poses_fill_commanded(tmp_path):
    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, poses={"home": {"commanded": [0.0, 0.1, 0.2]}}) as log:
        rec = log.record("home", "z", 1.0, unit="mm", instrument="caliper", resolution=0.02)
    assert rec.commanded == (0.0, 0.1, 0.2)


HAND_MADE = """pose_id,quantity,value,unit,resolution,commanded
p1,x,0.27,m,0.0005,0.0873 0 0
p1,y,0.024,m,0.0005,0.0873 0 0
"""


@pytest.mark.parametrize(
    "old, new, row, column",
    [
        ("0.024,m", "abc,m", 3, "value"),
        ("0.024,m", "0.024,inch", 3, "unit"),
        ("0.024,m", "0.024,deg", 3, "unit"),
        ("p1,y", "p1,q", 3, "quantity"),
        ("0.27,m,0.0005", "0.27,m,", 2, "resolution"),
        ("0.0873 0 0\np1", "0.0873 x 0\np1", 2, "commanded"),
        ("pose_id,", "pose,", 1, "pose_id"),
        (",resolution,", ",res,", 1, "resolution"),
    ],
)
def test_loader_names_row_and_column(tmp_path, old, new, row, column):
    path = tmp_path / "hand.csv"
    assert old in HAND_MADE
    path.write_text(HAND_MADE.replace(old, new, 1))
    with pytest.raises(MeasurementError, match=f"row {row}, column '{column}'") as info:
        load_measurements(path)
    assert (info.value.line, info.value.column) == (row, column)
    assert not hasattr(info.value, "row")


def test_measurement_error_stores_its_fields_as_passed():
    exc = MeasurementError("expected a number", path="hand.csv", line=3, column="reading")
    assert (exc.path, exc.line, exc.column) == ("hand.csv", 3, "reading")
    assert not hasattr(exc, "row")
    assert str(exc) == "hand.csv, row 3, column 'reading': expected a number"


def test_loader_unknown_pose(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text(HAND_MADE)
    assert len(load_measurements(path, poses={"p1"})) == 2
    with pytest.raises(MeasurementError, match="row 2, column 'pose_id'"):
        load_measurements(path, poses={"p2"})


def test_units_and_quantities():
    assert quantity_dimension("x") == "length"
    assert quantity_dimension("theta12") == "angle"
    assert quantity_dimension("d3") == "length"
    with pytest.raises(MeasurementError, match="theta<i>"):
        quantity_dimension("alpha")
    assert to_si(5.0, "cm") == pytest.approx(0.05)
    assert to_si(180.0, "deg") == pytest.approx(np.pi)
    np.testing.assert_allclose(to_si([1.0, 2.0], "mm"), [0.001, 0.002])


WRITER = textwrap.dedent(
    """
    import sys
    from labkit.measure import MeasurementLog
    log = MeasurementLog("arduino_arm_3dof", sys.argv[1])
    i = 0
    while True:
        rec = log.record("p%d" % (i % 5), "x", 0.001 * i, unit="m", instrument="sim",
                         resolution=0.0005, commanded=[0.1 * i, 0.0, 0.0], note="n" * (i % 50))
        print(rec.record, rec.pose_id, rec.repeat, repr(rec.value), flush=True)
        i += 1
    """
)


def _run_writer_and_kill(path, n_ack):
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    acks = []
    try:
        while len(acks) < n_ack:
            line = proc.stdout.readline()
            assert line, "writer died early"
            acks.append(line.split())
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    # the pipe may still hold acknowledgements printed just before the kill
    acks += [line.split() for line in proc.stdout.read().splitlines() if line.strip()]
    proc.stdout.close()
    return acks


def test_sigkill_loses_no_acknowledged_record(tmp_path):
    """Three writer processes in turn, each SIGKILLed mid-run; each resumes the last."""
    path = tmp_path / "crash.csv"
    acks = []
    for n_ack in (150, 40, 90):
        acks += _run_writer_and_kill(path, n_ack)
        with _maybe_warns():
            df = load_measurements(path)
        on_disk = {(int(r), p, int(k), float(v)) for r, p, k, v in
                   zip(df["record"], df["pose_id"], df["repeat"], df["value"])}
        missing = [a for a in acks if (int(a[0]), a[1], int(a[2]), float(a[3])) not in on_disk]
        assert not missing, missing[:5]
        # numbering continued across the crashes: no gaps, no duplicates
        assert list(df["record"]) == list(range(1, len(df) + 1))
        for _, reps in df.groupby("pose_id")["repeat"]:
            assert list(reps) == list(range(1, len(reps) + 1))
        assert df["session"].nunique() == 1
    # a resumed session in this process continues after the last record on disk
    last = len(df)
    with MeasurementLog(None, path) as log:
        rec = log.record("p0", "x", 1.0, unit="m", instrument="sim", resolution=0.0005)
    assert rec.record == last + 1
    assert rec.repeat == int(df.loc[df["pose_id"] == "p0", "repeat"].max()) + 1
    with _maybe_warns():
        assert len(load_measurements(path)) == last + 1


class _maybe_warns:
    """Context that tolerates (and records) MeasurementWarning for a torn tail."""

    def __enter__(self):
        import warnings

        self._ctx = warnings.catch_warnings(record=True)
        self.records = self._ctx.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        self._ctx.__exit__(*exc)
        others = [w for w in self.records if not issubclass(w.category, MeasurementWarning)]
        assert not others, others


def test_cut_inside_checksum_is_torn(tmp_path):
    path = tmp_path / "log.csv"
    _log_three(path)
    last = path.read_bytes().splitlines(keepends=True)[-1]
    with open(path, "ab") as f:
        f.write(last[:-4])  # everything but the last 3 hex digits and the newline
    with MeasurementLog(None, path) as log:
        rec = log.record("j1_45", "x", 18.4, unit="cm", instrument="ruler", resolution=0.05)
    assert rec.record == 4
    with pytest.warns(MeasurementWarning, match="row 5"):
        df = load_measurements(path)
    assert list(df["record"]) == [1, 2, 3, 4]


def test_edited_line_is_an_error_unless_check_blanked(tmp_path):
    path = tmp_path / "log.csv"
    _log_three(path)
    text = path.read_text()
    edited = text.replace(",18.2,", ",19.2,")
    path.write_text(edited)
    with pytest.raises(MeasurementError, match="row 3, column 'check'"):
        load_measurements(path)
    lines = edited.splitlines()
    lines[2] = lines[2][: lines[2].rfind(",") + 1]  # blank the checksum: accept the hand edit
    path.write_text("\n".join(lines) + "\n")
    assert list(load_measurements(path)["value"]) == [18.1, 19.2, 18.3]


def test_extra_field_is_an_error(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text(HAND_MADE + "p1,z,0.0,m,0.0005,0 0 0,surplus\n")
    with pytest.raises(MeasurementError, match="row 4.*expected 6 fields, got 7"):
        load_measurements(path)


def test_hand_made_file_without_final_newline_keeps_last_row(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text(HAND_MADE.rstrip("\n"))
    with pytest.warns(MeasurementWarning, match="kept"):
        df = load_measurements(path)
    assert list(df["value"]) == [0.27, 0.024]


def test_torn_header_is_repaired(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(",".join(COLUMNS)[:20])  # crash while writing the header
    with MeasurementLog(None, path, session="s") as log:
        log.record("p", "x", 1.0, unit="m", instrument="tape", resolution=0.001)
    with pytest.warns(MeasurementWarning, match="torn header"):
        df = load_measurements(path)
    assert list(df["value"]) == [1.0]


def test_concurrent_threads_get_unique_numbers(tmp_path):
    import threading

    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s") as log:
        def work(k):
            for _ in range(25):
                log.record(f"p{k}", "x", 1.0, unit="m", instrument="tape", resolution=0.001)

        threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    df = load_measurements(path)
    assert sorted(df["record"]) == list(range(1, 101))
    assert all(sorted(g) == list(range(1, 26)) for _, g in df.groupby("pose_id")["repeat"])


def test_excel_bom_and_crlf(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_bytes(b"\xef\xbb\xbf" + HAND_MADE.replace("\n", "\r\n").encode())
    df = load_measurements(path)
    assert list(df["quantity"]) == ["x", "y"]
    assert df.loc[1, "commanded"] == (0.0873, 0.0, 0.0)


def test_failed_write_is_not_glued_to_the_next_record(tmp_path, monkeypatch):
    import labkit.measure._log as m

    path = tmp_path / "log.csv"
    real_write = os.write
    with MeasurementLog(None, path, session="s") as log:
        log.record("p", "x", 1.0, unit="m", instrument="tape", resolution=0.001)

        def half_then_fail(fd, data):  # disk full after half a line
            real_write(fd, bytes(data[: len(data) // 2]))
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(m.os, "write", half_then_fail)
        with pytest.raises(OSError):
            log.record("p", "x", 2.0, unit="m", instrument="tape", resolution=0.001)
        monkeypatch.setattr(m.os, "write", real_write)
        rec = log.record("p", "x", 3.0, unit="m", instrument="tape", resolution=0.001)
    assert rec.record == 2  # the failed record was not acknowledged and is not counted
    with pytest.warns(MeasurementWarning, match="row 3"):
        df = load_measurements(path)
    assert list(df["value"]) == [1.0, 3.0]


def test_header_only_file_gives_typed_empty_frame(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("pose_id,quantity,value,unit,resolution\n")
    df = load_measurements(path)
    assert len(df) == 0
    assert df["value"].dtype == float and str(df["record"].dtype) == "Int64"
    assert not pd.api.types.is_numeric_dtype(df["pose_id"])
    (tmp_path / "nothing.csv").write_bytes(b"")
    with pytest.raises(MeasurementError, match="no header line"):
        load_measurements(tmp_path / "nothing.csv")


def test_a_full_disk_is_a_clear_labkit_error(tmp_path, monkeypatch):
    """Issue 13: a full disk surfaced as a bare OSError while logging."""
    import labkit.measure._log as m
    from labkit.exceptions import LabkitError, StorageError

    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s") as log:
        log.record("p", "x", 1.0, unit="m", instrument="tape", resolution=0.001)

        def full(fd, data):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(m.os, "write", full)
        with pytest.raises(StorageError, match=r"cannot write the measurement log .*log.csv: No space left on device; "
                                               r"the disk is full: free some space") as info:
            log.record("p", "x", 2.0, unit="m", instrument="tape", resolution=0.001)
    assert isinstance(info.value, LabkitError) and isinstance(info.value, OSError)


def _fail_after(monkeypatch, landed):
    """The next os.write in the log puts only ``landed`` bytes of its data on disk, then the disk is full."""
    import labkit.measure._log as m

    real_write = os.write

    def full(fd, data):
        real_write(fd, bytes(data[:landed]))
        monkeypatch.setattr(m.os, "write", real_write)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(m.os, "write", full)


def test_a_retry_after_a_full_disk_never_duplicates_a_record(tmp_path, monkeypatch):
    """Issue 27: the failed write lost only the newline or only the check field, and the retry added a copy."""
    from labkit.exceptions import StorageError
    from labkit.measure._schema import _encode_line

    args = dict(unit="m", instrument="tape", resolution=0.001)
    with MeasurementLog(None, tmp_path / "probe.csv", session="s") as log:
        log.record("p", "x", 1.0, **args)
        size = len(_encode_line(log.record("p", "x", 2.0, **args).to_row()).encode())
    for landed in sorted({0, 1, size // 2, size - 10, size - 9, size - 8, size - 2, size - 1, size}):
        path = tmp_path / f"cut{landed}.csv"
        with MeasurementLog(None, path, session="s") as log:
            log.record("p", "x", 1.0, **args)
            _fail_after(monkeypatch, landed)
            with pytest.raises(StorageError):
                log.record("p", "x", 2.0, **args)
            retry = log.record("p", "x", 2.0, **args)  # what the error message tells the user to do
            after = log.record("p", "x", 3.0, **args)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeasurementWarning)
            df = load_measurements(path)
        assert list(df["value"]) == [1.0, 2.0, 3.0], (landed, path.read_text())
        assert list(df["record"]) == [1, 2, 3] and list(df["repeat"]) == [1, 2, 3], landed
        assert (retry.record, after.record) == (2, 3), landed
        # resumed, the file goes on with the next number
        with warnings.catch_warnings():
            warnings.simplefilter("error", MeasurementWarning)
            assert MeasurementLog(None, path).record("p", "x", 4.0, **args).record == 4


def test_a_retry_with_another_reading_keeps_the_one_on_disk(tmp_path, monkeypatch):
    from labkit.exceptions import StorageError
    from labkit.measure._schema import _encode_line

    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s") as log:
        rec = log.record("p", "x", 1.0, unit="m", instrument="tape", resolution=0.001)
        _fail_after(monkeypatch, len(_encode_line(rec.to_row()).encode()) - 1)  # only the newline lost
        with pytest.raises(StorageError):
            log.record("p", "x", 2.0, unit="m", instrument="tape", resolution=0.001)
        other = log.record("p", "y", 5.0, unit="m", instrument="tape", resolution=0.001)
    df = load_measurements(path)
    assert list(df["value"]) == [1.0, 2.0, 5.0] and list(df["record"]) == [1, 2, 3] and other.record == 3


@pytest.mark.parametrize("cut", ["after_last_comma", "inside_check", "inside_note"])
def test_a_torn_tail_is_reported_and_never_loaded(tmp_path, cut):
    path = tmp_path / "log.csv"
    with MeasurementLog(None, path, session="s") as log:
        log.record("p", "x", 1.0, unit="m", instrument="tape", resolution=0.001, note="a, b")
        log.record("p", "x", 2.0, unit="m", instrument="tape", resolution=0.001, note="a, b")
    text = path.read_text()
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    keep = {"after_last_comma": last.rfind(",") + 1, "inside_check": len(last) - 4,
            "inside_note": last.index('"a,') + 3}[cut]
    path.write_text(text[: len(text) - len(last) - 1] + last[:keep])
    with pytest.warns(MeasurementWarning, match="last line was torn"):
        log = MeasurementLog(None, path)
    rec = log.record("p", "x", 3.0, unit="m", instrument="tape", resolution=0.001)
    log.close()
    assert rec.record == 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeasurementWarning)
        df = load_measurements(path)
    assert list(df["value"]) == [1.0, 3.0] and list(df["record"]) == [1, 2]
