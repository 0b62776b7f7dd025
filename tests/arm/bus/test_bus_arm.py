"""Arm end to end on the virtual Dynamixel and Feetech buses: moves, trajectories, read-back, streams, faults."""

import math
import time
from pathlib import Path

import numpy as np
import pytest

from labkit.arm import Arm
from labkit.exceptions import DeviceError, JointLimitError, TrajectoryError
from labkit.motion import joint_trajectory


def _url(robot_file, kind):
    return f"sim://{robot_file}?bus={kind}&clock=lockstep"


@pytest.fixture
def arm(robot_file, kind):
    with Arm(robot_file, _url(robot_file, kind)) as arm:
        yield arm


def _torques(arm, settle=False):
    emu = arm.port.emulator
    deadline = time.monotonic() + (60.0 if settle else 0.0)  # the emulator's thread runs when the host's CPU runs it
    while settle and any(emu.torque(i) for i in emu.ids) and time.monotonic() < deadline:
        time.sleep(0.01)  # a torque-off whose status packet was lost may still be on its way to the bus
    return [emu.torque(i) for i in emu.ids]


def test_opening_starts_where_the_arm_rests_with_torque_on(arm):
    emu = arm.port.emulator
    assert _torques(arm) == [True] * arm.robot.n
    assert np.allclose(arm.commanded_joints(), arm.robot.joint_limits.mean(axis=1), atol=math.radians(0.1))
    names = {p[0] for p in emu.packets}
    assert {"ping", "write", "sync write", "sync read"} <= names and emu.rejected == []


@pytest.mark.parametrize("readings", ["one damaged", "never agreeing"])
def test_a_damaged_reading_at_open_is_never_taken_for_the_pose(robot_file, kind, monkeypatch, readings):
    """A status packet that passes Feetech's 8-bit checksum by chance (1 in 256 of the damaged or misaligned ones)
    carries a wrong position: at power-up it would become a goal, or refuse the arm as out of its limits."""
    import dataclasses

    from labkit.arm.bus import bus_module

    driver = bus_module(kind).Driver
    real, calls = driver.read_state, []

    def read_state(self, t=0.0):
        reading = real(self, t)
        calls.append(t)
        if len(calls) == 1 or (readings == "never agreeing" and len(calls) % 2):
            q = reading.q.copy()
            q[1] += 2.0  # [rad]: far outside the joint's limits
            return dataclasses.replace(reading, q=q, ticks=reading.ticks + np.eye(len(q), dtype=int)[1] * 1300)
        return reading

    monkeypatch.setattr(driver, "read_state", read_state)
    if readings == "never agreeing":
        with pytest.raises(DeviceError, match=r"the present positions of servo \d+ \(joint '\w+'\) differ from one "
                                              r"sync read to the next after 9 reads"):
            Arm(robot_file, _url(robot_file, kind))
        return
    with Arm(robot_file, _url(robot_file, kind)) as arm:
        emu = arm.port.emulator
        assert len(calls) >= 3  # the damaged read, then two that agree
        assert np.allclose(arm.commanded_joints(), arm.robot.joint_limits.mean(axis=1), atol=math.radians(0.1))
        assert [emu.get(i, "goal_position") for i in emu.ids] == [emu.get(i, "present_position") for i in emu.ids]


def test_move_joints_then_read_back_through_the_bus(arm):
    emu = arm.port.emulator
    target = np.radians([30.0, 20.0, -10.0, 15.0])
    writes = emu.sync_writes
    arm.move_joints(target, wait=True)
    assert emu.sync_writes > writes + 5  # the executor's cubic, frame by frame, one packet for all joints
    q = arm.read_joints()
    assert np.allclose(q, target, atol=math.radians(0.5))
    ticks = [emu.get(lk.bus.id, "present_position") for lk in arm.robot.links]
    assert np.allclose([lk.bus.joint(t) for lk, t in zip(arm.robot.links, ticks)], q, atol=1e-12)
    assert np.allclose(arm.virtual_model.shaft_q, target, atol=math.radians(0.5))
    load = arm.read_load()
    assert load.shape == (4,) and abs(load[0]) < 1e-9 and abs(load[1]) > 0.05  # the base carries no gravity
    assert emu.rejected == []


def test_trajectory_and_stream_with_the_load_signal(arm):
    start = arm.commanded_joints()
    goal = start + np.radians([20.0, -15.0, 10.0, 5.0])
    traj = joint_trajectory(None, start, goal, 1.0)
    report = arm.run_trajectory(traj)
    assert report.segments >= 10
    assert np.allclose(arm.commanded_joints(), goal, atol=math.radians(0.02))
    df = arm.stream(0.4, hz=50)
    assert len(df) == df.attrs["expected"] >= 19 and df.attrs["lost"] == 0
    names = arm.robot.joint_names
    assert {f"q_{n}" for n in names} | {f"current_{n}" for n in names} <= set(df.columns)
    assert np.allclose(df[[f"q_{n}" for n in names]].to_numpy()[-1], goal, atol=math.radians(1.0))
    assert (df[f"current_{names[1]}"].abs() > 0.05).all()


def test_limits_refused_before_anything_is_sent(arm):
    emu = arm.port.emulator
    before = len(emu.packets), emu.sync_writes
    with pytest.raises(JointLimitError, match="shoulder"):
        arm.move_joints(np.radians([0.0, 95.0, 0.0, 0.0]))
    start = arm.commanded_joints()
    fast = joint_trajectory(None, start, start + np.radians([90.0, 0, 0, 0]), 0.2)  # 120 deg/s allowed
    with pytest.raises(TrajectoryError):
        arm.run_trajectory(fast)
    assert (len(emu.packets), emu.sync_writes) == before


@pytest.mark.parametrize("fault", ["drop_status", "corrupt_status", "overload", "silent"])
def test_a_bus_fault_stops_the_arm_with_torque_off(arm, fault):
    emu = arm.port.emulator
    shoulder = arm.robot.links[1].bus.id
    if fault == "overload":
        emu.faults.overload.add(shoulder)
    elif fault == "silent":
        emu.faults.silent.add(shoulder)
    else:
        setattr(emu.faults, fault, 100_000)  # every status packet: more than the bounded retries absorb
    expected = {"overload": "overload", "silent": "no intact status packet"}.get(fault, "no intact status packet")
    with pytest.raises(DeviceError, match=expected) as info:
        arm.move_joints(arm.commanded_joints() + np.radians([10.0, 10.0, 0, 0]), wait=True)
    assert "torque is off on every servo" in str(info.value) or fault != "overload"
    assert "port vanished" not in str(info.value)
    setattr(emu.faults, fault, set() if fault in ("overload", "silent") else 0)
    assert _torques(arm, settle=True) == [False] * arm.robot.n
    with pytest.raises(DeviceError):  # the board stays stopped until the port is closed
        arm.read_joints()


def test_closing_turns_torque_off(robot_file, kind):
    arm = Arm(robot_file, _url(robot_file, kind))
    emu = arm.port.emulator
    assert _torques(arm) == [True] * arm.robot.n
    arm.close()
    assert [emu.memory[i][emu.bus.TABLE["torque_enable"][0]] for i in emu.ids] == [0] * arm.robot.n


def test_the_dynamixel_url_drives_a_bus_on_its_device():
    from labkit.arm.bus import BusEmulator
    from tests.arm.bus.conftest import ROBOTS

    with BusEmulator(ROBOTS["dynamixel"], wall_clock=True) as emu:
        with Arm(ROBOTS["dynamixel"], f"dynamixel://{emu.path}?baud=1000000&latency=100") as arm:
            assert arm.virtual_model is None  # a "real" bus: nothing simulated on this side
            target = arm.commanded_joints() + np.radians([5.0, 0.0, 0.0, -5.0])
            arm.move_joints(target, wait=True)
            assert np.allclose(arm.read_joints(), target, atol=math.radians(0.5))
        assert [emu.torque(i) for i in emu.ids] == [False] * 4
        assert emu.rejected == []


def test_a_servo_that_does_not_answer_is_named_at_open():
    from labkit.arm.bus import BusEmulator
    from tests.arm.bus.conftest import ROBOTS

    with BusEmulator(ROBOTS["feetech"], wall_clock=True) as emu:
        emu.faults.silent.add(3)
        with pytest.raises(DeviceError, match=r"servo 3 \(joint 'elbow'\) does not answer ping"):
            Arm(ROBOTS["feetech"], f"feetech://{emu.path}?latency=100")


def test_a_bus_url_needs_a_robot_with_that_bus(robot_file):
    with pytest.raises(DeviceError, match="bus"):
        Arm("arduino_arm_3dof", "feetech:///dev/null-no-such")
    with pytest.raises(DeviceError, match="expected bus one of dynamixel, feetech"):
        Arm(robot_file, f"sim://{robot_file}?bus=can")
    with pytest.raises(DeviceError, match="hobby servos"):
        with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as plain:
            plain.read_load()


def test_lockstep_runs_on_a_virtual_bus_repeat_exactly(robot_file, kind):
    def run():
        with Arm(robot_file, _url(robot_file, kind) + "&seed=3") as arm:
            arm.move_joints(arm.commanded_joints() + np.radians([15.0, -10.0, 5.0, 0.0]))
            df = arm.stream(0.2, hz=50)
            return df.to_numpy(), arm.virtual_model.true_q

    (a, qa), (b, qb) = run(), run()
    assert np.array_equal(a, b) and np.array_equal(qa, qb)


def test_a_program_that_ends_with_the_arm_open_turns_torque_off(tmp_path):
    import os
    import subprocess
    import sys

    from tests.arm.bus.conftest import ROBOTS

    script = tmp_path / "forget_to_close.py"
    script.write_text(f"""
import atexit, time
from labkit.arm import Arm
from labkit.arm.bus import BusEmulator
emu = BusEmulator({ROBOTS['dynamixel']!r}, wall_clock=True)
atexit.register(lambda: print("after", [emu.torque(i) for i in emu.ids]))  # runs after the board's handler
arm = Arm({ROBOTS['dynamixel']!r}, f"dynamixel://{{emu.path}}?latency=100")
print("before", [emu.torque(i) for i in emu.ids])
""", encoding="utf-8")
    root = Path(__file__).parents[3]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    # a guard against a hang, not a speed limit: a loaded machine takes minutes to import and open
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "before [True, True, True, True]" in out.stdout and "after [False, False, False, False]" in out.stdout
