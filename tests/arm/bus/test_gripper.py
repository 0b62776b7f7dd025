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


def test_gripper_writes_are_read_back_and_sent_again_until_the_servo_holds_them(bus_arm, monkeypatch):
    """Issue 41: the gripper's goal and limit go through the confirmed write of the joints' goals, torque and gains."""
    from tests.arm.bus.test_confirm import _ignore_writes

    kind, arm = bus_arm
    emu = arm.port.emulator
    g = arm.robot.gripper
    sid = g.servo.id
    held = 0.25 * g.open + 0.75 * g.closed
    _ignore_writes(monkeypatch, emu, sid, "goal_position", times=2)  # two lost writes: sent again, read back
    field, value = limit_register(emu.bus, 0.4)
    writes = emu.sync_writes
    arm.move_gripper(held, max_torque=0.4)
    assert emu.get(sid, "goal_position") == int(g.servo.ticks(held)) and emu.get(sid, field) == value
    assert emu.sync_writes - writes == 4  # the limit once, the goal three times


@pytest.mark.parametrize("field", ["goal_position", "limit"])
def test_a_gripper_servo_that_never_holds_a_value_is_a_bus_fault_naming_it(bus_arm, monkeypatch, field):
    from labkit.arm.bus._confirm import WRITE_TRIES
    from labkit.exceptions import BusFault
    from tests.arm.bus.test_confirm import _ignore_writes

    kind, arm = bus_arm
    emu = arm.port.emulator
    g = arm.robot.gripper
    sid = g.servo.id
    if field == "limit":
        field = limit_register(emu.bus, 0.3)[0]
    _ignore_writes(monkeypatch, emu, sid, field)
    with pytest.raises(BusFault, match=rf"{field} not confirmed after {WRITE_TRIES} sync writes and read-backs "
                                       rf"\(servo {sid} \(gripper\) was sent \d+, holds \d+\)"):
        arm.move_gripper(g.closed, max_torque=0.3)
    assert not any(emu.torque(i) for i in [*emu.ids, sid])  # the arm is stopped, torque off (the gripper too)
