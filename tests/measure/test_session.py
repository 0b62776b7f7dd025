"""Measurement sessions on the virtual arm: seed 000 II.4 sweeps -> error tables -> calibration."""

import math

import numpy as np
import pytest
import serial

from labkit.exceptions import DeviceError, MeasurementError
from labkit.arm import FaultConfig, FaultyPort
from labkit.arm import Arm
from labkit.measure import load_measurements
from labkit.measure import (
    SEED000_SWEEPS,
    MeasurementSession,
    PlannedPose,
    joint_sweep_plan,
    manual_form,
    prompt_reading,
)
from labkit.arm.urlhandler import register

register()
SIM = "sim://arduino_arm_3dof?clock=lockstep&seed=0"


def test_seed000_plan():
    plan = joint_sweep_plan("arduino_arm_3dof", SEED000_SWEEPS)
    assert len(plan) == 15
    assert [p.pose_id for p in plan[:5]] == ["j1_5", "j1_45", "j1_60", "j1_90", "j1_120"]
    assert [p.pose_id for p in plan[10:]] == ["j3_5", "j3_20", "j3_45", "j3_60", "j3_80"]  # the seed's table 3
    np.testing.assert_allclose(plan[6].q, [0.0, math.radians(45), 0.0])
    with pytest.raises(ValueError, match="joint numbers 1..3"):
        joint_sweep_plan("arduino_arm_3dof", {4: [10]})


@pytest.mark.slow
def test_seed000_section_II4_sweeps_error_tables_and_calibration(tmp_path):
    from labkit.measure import calibrate
    from labkit.measure import error_table

    path = tmp_path / "sweep.csv"
    with Arm("arduino_arm_3dof", SIM) as arm:
        offsets = arm.port.board.model.zero_offsets.copy()
        df = MeasurementSession(arm, path, source="ruler", readings=3).run(joint_sweep_plan(arm.robot, SEED000_SWEEPS))
    assert len(df) == 15 * 3 * 3
    assert set(df["unit"]) == {"mm"} and set(df["resolution"]) == {0.5}
    result = error_table("arduino_arm_3dof", path)
    table = result.table
    assert len(table) == 45
    # size: errors of a few millimetres, like the seed's (which adds a hand-held ruler's scatter)
    assert 2.0 < result.summary.loc["z", "rms_error"] < 15.0
    assert result.summary["max_abs_error"].max() < 20.0
    # direction: the arm sags; the seed-000 base z axis points down, so measured z exceeds the model's,
    # as in the seed's tables 2 and 3 (z measured -0.17 for -0.19 at 45 deg; 0.04 for 0.014 at 5 deg)
    z = table[table["quantity"] == "z"].set_index("pose_id")["error"]
    assert (z > 0).mean() > 0.8
    assert z["j2_45"] > 0 and z["j3_5"] > 0 and z["j3_20"] > 0
    # calibration recovers the injected zero offsets (with the sag modelled)
    cal = calibrate("arduino_arm_3dof", path, params=("joint_offsets", "gravity_sag"), gravity=(0, 0, 1))
    par = cal.parameters()
    for j in range(3):
        row = par.loc[f"offset[{j + 1}]"]
        assert row["ci_low"] <= math.degrees(offsets[j]) <= row["ci_high"]
        assert row["fitted"] == pytest.approx(math.degrees(offsets[j]), abs=0.25)
    assert cal.rms_after < 0.5e-3 < 3e-3 < cal.rms_before


def test_feedback_readings(tmp_path):
    plan = [PlannedPose("a", (0.5, 1.0, 1.5)), PlannedPose("b", (1.0, 0.3, 0.2))]
    with Arm("arduino_arm_3dof", SIM) as arm:
        df = MeasurementSession(arm, tmp_path / "fb.csv", source="feedback", readings=4).run(plan)
    assert len(df) == 2 * 4 * 3
    assert set(df["quantity"]) == {"theta1", "theta2", "theta3"} and set(df["unit"]) == {"deg"}
    for pose in plan:
        rows = df[df["pose_id"] == pose.pose_id]
        for j in range(3):
            vals = rows[rows["quantity"] == f"theta{j + 1}"]["value"]
            assert abs(vals.mean() - math.degrees(pose.q[j])) < 1.0
    assert df["resolution"].iloc[0] == pytest.approx(180 / 818.4, rel=1e-3)


def test_manual_readings_are_validated(tmp_path, capsys):
    answers = iter(["", "abc", "1e9", "100", "0", "-50"] + ["10", "20", "30"] * 3)
    plan = [PlannedPose("p1", (0.5, 0.5, 0.5))]
    with Arm("arduino_arm_3dof", SIM) as arm:
        session = MeasurementSession(arm, tmp_path / "m.csv", source="manual", readings=2, unit="mm",
                                     input=lambda prompt: next(answers))
        df = session.run(plan)
    out = capsys.readouterr().out
    assert "expected a number, got ''" in out and "expected a value between" in out
    assert list(df["value"][:3]) == [100.0, 0.0, -50.0] and len(df) == 6
    with pytest.raises(MeasurementError, match="no valid reading"):
        prompt_reading("p x", "mm", input=lambda prompt: "nan", attempts=2)


def test_manual_form_records_and_advances(tmp_path):
    plan = joint_sweep_plan("arduino_arm_3dof", {1: [30, 60]})
    with Arm("arduino_arm_3dof", SIM) as arm:
        session = MeasurementSession(arm, tmp_path / "form.csv", source="manual", readings=1, unit="cm")
        form = manual_form(session, plan)
        title, fx, fy, fz, buttons, message = form.children
        move, record = buttons.children
        assert "j1_30" in title.value
        move.click()
        assert message.value == "arrived"
        fx.value, fy.value, fz.value = "23.5", "13", "oops"
        record.click()
        assert "expected a number" in message.value
        fz.value = "0.5"
        record.click()
        assert "j1_60" in title.value and fx.value == ""
        df = session.log.to_dataframe()
    assert list(df["value"]) == [23.5, 13.0, 0.5] and set(df["unit"]) == {"cm"}


def test_ruler_needs_the_virtual_arm(tmp_path):
    class BarePort:  # a port without a simulated board behind it
        def __init__(self, port):
            self._p = port

        timeout = property(lambda self: self._p.timeout, lambda self, v: setattr(self._p, "timeout", v))
        in_waiting = property(lambda self: self._p.in_waiting)

        def read(self, n=1):
            return self._p.read(n)

        def write(self, data):
            return self._p.write(data)

        def close(self):
            self._p.close()

    with Arm("arduino_arm_3dof", BarePort(serial.serial_for_url(SIM, timeout=0.05)), timeout=0.05) as arm:
        with pytest.raises(DeviceError, match="source='manual'"):
            MeasurementSession(arm, tmp_path / "x.csv", source="ruler")
    with Arm("arduino_arm_3dof", SIM) as arm, pytest.raises(ValueError, match="expected source one of"):
        MeasurementSession(arm, tmp_path / "y.csv", source="laser")


def test_no_acknowledged_measurement_is_lost_when_the_link_dies(tmp_path):
    path = tmp_path / "crash.csv"
    raw = serial.serial_for_url(SIM, timeout=0.05)
    port = FaultyPort(raw, FaultConfig(disconnect_after=1000))
    acknowledged = []
    with Arm("arduino_arm_3dof", port, timeout=0.02) as arm:
        session = MeasurementSession(arm, path, source="ruler", readings=3)
        with pytest.raises(DeviceError, match="vanished"):
            for pose in joint_sweep_plan(arm.robot, SEED000_SWEEPS):
                acknowledged += session.measure(pose)
        session.log.close()
    assert 0 < len(acknowledged) < 135
    df = load_measurements(path)
    assert list(df["record"]) == [r.record for r in acknowledged]
    np.testing.assert_array_equal(df["value"], [r.value for r in acknowledged])


def test_sweep_defaults_match_seed_tables():
    assert SEED000_SWEEPS[1] == (5.0, 45.0, 60.0, 90.0, 120.0)
    assert SEED000_SWEEPS[3] == (5.0, 20.0, 45.0, 60.0, 80.0)
