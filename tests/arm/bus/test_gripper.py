"""The gripper servo of a bus arm on both virtual buses: open, close on an object with the grip limit, position.

The bundled OpenMANIPULATOR-X (Dynamixel, current-based position mode, Goal Current as the limit) and
SO-101 (Feetech, Torque_Limit as the limit) robot files describe their grippers as bus servos.
"""

import math

import pytest

from labkit.arm import Arm
from labkit.arm.bus import limit_register
from labkit.exceptions import OptionError
from labkit.robot import BusGripper, Robot

ARMS = {"dynamixel": "openmanipulator_x", "feetech": "so101"}


@pytest.fixture(params=sorted(ARMS))
def bus_arm(request):
    kind = request.param
    with Arm(ARMS[kind], f"sim://{ARMS[kind]}?bus={kind}&clock=lockstep") as arm:
        yield kind, arm


def test_the_gripper_opens_closes_on_an_object_with_its_limit_and_is_restored_on_close(bus_arm):
    kind, arm = bus_arm
    emu = arm.port.emulator
    g = arm.robot.gripper
    sid = g.servo.id
    assert isinstance(g, BusGripper) and emu.torque(sid)
    field, value = limit_register(emu.bus, g.max_torque)
    assert emu.get(sid, field) == value  # the robot file's grip limit is in the servo's register
    if kind == "dynamixel":
        assert emu.get(sid, "operating_mode") == 5  # current-based position control
    arm.open_gripper()
    arm.sleep(1.0)
    assert arm.read_gripper().position == pytest.approx(g.open, abs=math.radians(0.2))
    held = 0.5 * (g.open + g.closed)
    emu.gripper.object = held  # something between the jaws
    arm.close_gripper()
    arm.sleep(1.0)
    state = arm.read_gripper()
    assert state.position == pytest.approx(held, abs=math.radians(0.2)) and state.goal == pytest.approx(g.closed)
    assert abs(state.current) * emu.bus.TORQUE_CONSTANT == pytest.approx(g.max_torque, rel=0.02)  # squeezes at the limit
    arm.close_gripper(max_torque=0.3)
    arm.sleep(0.2)
    assert abs(arm.read_gripper().current) * emu.bus.TORQUE_CONSTANT == pytest.approx(0.3, rel=0.02)
    emu.gripper.object = None
    arm.sleep(1.0)
    state = arm.read_gripper()
    assert state.position == pytest.approx(g.closed, abs=math.radians(0.2)) and state.current == 0
    arm.move_gripper(held)
    arm.sleep(1.0)
    assert arm.read_gripper().position == pytest.approx(held, abs=math.radians(0.2))
    arm.close()
    assert not emu.torque(sid) and emu.get(sid, field) == (1193 if kind == "dynamixel" else 1000)
    if kind == "dynamixel":
        assert emu.get(sid, "operating_mode") == 3  # the mode it had, written back


def test_bad_gripper_requests_are_refused_before_anything_is_written(bus_arm):
    kind, arm = bus_arm
    emu = arm.port.emulator
    g = arm.robot.gripper
    sent = len(emu.packets)
    stall = emu.bus.MOTOR["stall_torque"]
    for position in (g.open - 0.2 * math.copysign(1, g.closed - g.open), math.nan, "open", None):
        with pytest.raises(OptionError, match=rf"gripper servo {g.servo.id}: expected a position"):
            arm.move_gripper(position)
    for torque in (0.0, -1.0, stall * 1.5, math.inf):
        with pytest.raises(OptionError, match=rf"expected max_torque in \(0, {stall:g}\] N m"):
            arm.close_gripper(max_torque=torque)
    assert [p for p in emu.packets[sent:] if p[1] == g.servo.id and p[0] == "write"] == []


def test_a_robot_file_gripper_on_the_bus_round_trips_and_is_checked(tmp_path):
    robot = Robot.load("openmanipulator_x")
    path = tmp_path / "omx.toml"
    robot.to_toml(path)
    back = Robot.load(path).gripper
    assert back.servo == robot.gripper.servo and back.max_torque == robot.gripper.max_torque
    assert (back.open, back.closed) == pytest.approx((robot.gripper.open, robot.gripper.closed), abs=1e-11)
    text = path.read_text()
    bad = text.replace("bus = { id = 15,", "bus = { id = 14,")
    path.write_text(bad)
    with pytest.raises(ValueError, match="distinct servo ids"):
        Robot.load(path)
    path.write_text(text.replace("max_torque = 0.5", "max_torque = -1"))
    with pytest.raises(ValueError, match="max_torque"):
        Robot.load(path)
