"""Bad input to a bus arm is a LabkitError (issue 41): stream rates, moves, URL options and robot files with huge
bus numbers, swept with hypothesis; nothing bad reaches the servos."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labkit.arm import Arm
from labkit.arm.urlhandler.bus_port import parse_bus_url
from labkit.exceptions import JointLimitError, LabkitError, OptionError, RobotError
from labkit.robot import BusServo, Robot
from tests.arm.bus.conftest import ROBOTS

ANY = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.text(max_size=8),
                st.floats(allow_nan=True, allow_infinity=True), st.lists(st.floats(), max_size=5),
                st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 2**63, 0.5, 0, 50, 200]))


@pytest.fixture(scope="module")
def bus_arm():
    with Arm(ROBOTS["feetech"], f"sim://{ROBOTS['feetech']}?bus=feetech&clock=lockstep") as arm:
        yield arm


@pytest.mark.parametrize("hz", [math.nan, math.inf, -math.inf, "50", None, True])
def test_a_stream_rate_that_is_not_a_finite_number_says_so_like_sim(bus_arm, hz):
    with pytest.raises(OptionError, match=r"expected hz as a finite number, got"):
        bus_arm.stream(0.2, hz=hz)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(duration=ANY, hz=ANY)
def test_stream_arguments_are_checked_before_anything_is_sent(bus_arm, duration, hz):
    emu = bus_arm.port.emulator
    ok_duration = isinstance(duration, (int, float)) and not isinstance(duration, bool) \
        and math.isfinite(duration) and duration > 0
    ok_hz = isinstance(hz, (int, float)) and not isinstance(hz, bool) and math.isfinite(hz) and hz == int(hz) \
        and 1 <= hz <= 200
    if ok_duration and ok_hz:
        return  # a valid stream records (test_bus_arm); here only what must be refused
    before = len(emu.packets)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow or cast warning on the way to the error
        with pytest.raises(LabkitError):
            bus_arm.stream(duration, hz=hz)
    assert len(emu.packets) == before


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(q=st.one_of(ANY, st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=4, max_size=4)))
def test_moves_to_bad_joint_values_are_refused_before_the_bus_sees_them(bus_arm, q):
    emu = bus_arm.port.emulator
    goals = [emu.get(i, "goal_position") for i in emu.ids]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            bus_arm.move_joints(q, wait=True)
        except LabkitError:
            assert [emu.get(i, "goal_position") for i in emu.ids] == goals
            return
    # accepted: a finite configuration within the limits, and every servo holds the host's goal for it
    assert np.all(np.isfinite(np.asarray(q, float)))
    assert [emu.get(lk.bus.id, "goal_position") for lk in bus_arm.robot.links] == \
        [int(lk.bus.ticks(v)) for lk, v in zip(bus_arm.robot.links, bus_arm.commanded_joints())]


@settings(max_examples=80, deadline=None)
@given(key=st.sampled_from(["baud", "queue", "latency", "speed", ""]),
       value=st.one_of(st.text(max_size=12), st.sampled_from(["nan", "inf", "-1", "1e308", "1" * 40, "0x10"])))
def test_bus_url_options_are_labkit_errors(key, value):
    url = f"dynamixel:///dev/ttyUSB0?{key}={value}"
    try:
        protocol, device, options = parse_bus_url(url)
    except LabkitError:
        return
    assert protocol == "dynamixel" and device == "/dev/ttyUSB0"
    if options["latency"] is not None:
        assert 0 <= options["latency"] <= 1000
    if options["baud"] is not None:
        assert 9600 <= options["baud"] <= 4_500_000


@pytest.mark.parametrize("old, new", [
    ("limits = [-160, 160]", "limits = [-1e300, 1e300]"),
    ("limits = [-160, 160]", "limits = [-1e20, 160]"),
    ("limits = [-160, 160]", "limits = [-400, 160]"),
    ("zero = 2048, direction = 1", "zero = 1e300, direction = 1"),
    ("resolution = 4096", "resolution = 99999999999999999999"),
    ("resolution = 4096", "resolution = 4096\nlatency = 1e300"),
    ("resolution = 4096", "resolution = 4096\nlatency = -1"),
])
def test_robot_files_with_huge_bus_numbers_are_refused_at_load_without_numpy_warnings(tmp_path, old, new):
    text = open(ROBOTS["dynamixel"], encoding="utf-8").read()
    assert old in text
    path = tmp_path / "huge.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(RobotError, match=r"expected"):
            Robot.load(str(path))


@pytest.mark.parametrize("q", [math.nan, math.inf, 1e300, [0.0, 1e300], 1e308, [0.0, -1.7e308]])  # 1e308 rad overflows in ticks
def test_bus_servo_ticks_of_a_value_no_servo_can_reach_is_a_joint_limit_error(q):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(JointLimitError, match="BusServo 11: expected finite joint values"):
            BusServo(11).ticks(q)


def test_a_huge_profile_velocity_is_clamped_to_what_the_register_takes(tmp_path):
    text = open(ROBOTS["dynamixel"], encoding="utf-8").read().replace("max_velocity = 120", "max_velocity = 1e300", 1)
    path = tmp_path / "fast.toml"
    path.write_text(text, encoding="utf-8")
    with Arm(str(path), f"sim://{path}?bus=dynamixel&clock=lockstep") as arm:
        emu = arm.port.emulator
        assert emu.get(emu.ids[0], "profile_velocity") == 32767


def test_a_url_alone_is_the_port_and_its_robot_the_one_it_names():
    with Arm("sim://openmanipulator_x?bus=dynamixel&clock=lockstep") as arm:
        assert arm.robot.name == "openmanipulator_x" and arm.robot.n == 4
        assert arm.port.emulator is not None
    with pytest.raises(OptionError, match=r"expected the arm's robot \(Arm\(robot, port\)"):
        Arm("dynamixel:///dev/ttyUSB0")
