"""One board interface: every board kind is a BoardPort; the host asks nothing else; a new bus protocol is one
codec module and one registry entry; the boards share the executor by holding it, not by inheriting a board."""

import ast
import importlib
import inspect
import math
import pkgutil
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import serial

import labkit.arm.bus
from labkit.arm import Arm, ArduinoPort, ArmModel, BoardPort, Executor, FaultConfig, FaultyPort, Servos, VirtualBoard
from labkit.arm.bus import BUSES, BusBoard, BusReading, bus_module
from labkit.arm.urlhandler import register
from labkit.arm.urlhandler.board_serial import BoardSerial
from labkit.arm.urlhandler.bus_port import BusSerial
from labkit.arm.urlhandler.protocol_sim import Serial as SimSerial

ARM = Path(labkit.arm.__file__).parent
BUS_ROBOTS = {"dynamixel": "tests/arm/bus/omx_test.toml", "feetech": "tests/arm/bus/so101_test.toml"}

register()


def _sim(kind):
    if kind == "sim":
        return serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.05)
    return serial.serial_for_url(f"sim://{BUS_ROBOTS[kind]}?bus={kind}&clock=lockstep", timeout=0.05)


@pytest.mark.parametrize("kind", ["sim", "dynamixel", "feetech"])
def test_every_in_process_board_is_a_board_port(kind):
    port = _sim(kind)
    try:
        assert isinstance(port, BoardPort) and isinstance(port, BoardSerial)
        assert isinstance(port.board.executor, Executor) and isinstance(port.board, Servos)
        assert not isinstance(port.board, Executor)  # held, not inherited
        assert port.clock == "lockstep" and port.time_scale == 1.0 and port.board_time >= 0.0
        assert isinstance(port.virtual_model, ArmModel)
        reading = port.read_servos()
        if kind == "sim":
            assert reading is None and port.servo_stream() is None  # its joints come back as READ and FB lines
        else:
            assert isinstance(reading, BusReading) and reading.q.shape == (4,) and reading.current.shape == (4,)
            assert port.servo_stream() == []
        wrapped = FaultyPort(port, FaultConfig(seed=1))
        assert isinstance(wrapped, BoardPort) and wrapped.virtual_model is port.virtual_model
    finally:
        port.close()


def test_the_firmware_in_simavr_is_a_board_port():
    port = serial.serial_for_url("simavr://?physics=1", baudrate=115200, timeout=1)
    try:
        assert isinstance(port, BoardPort)
        assert port.clock == "lockstep" and port.board_time >= 0.0
        assert isinstance(port.virtual_model, ArmModel) and port.read_servos() is None and port.servo_stream() is None
    finally:
        port.close()


def test_a_real_boards_port_is_wrapped_as_a_board_port():
    raw = serial.serial_for_url("loop://", timeout=0.01)
    assert not isinstance(raw, BoardPort)
    port = ArduinoPort(raw)
    assert isinstance(port, BoardPort)
    assert port.board_time is None and port.clock == "realtime" and port.time_scale == 1.0
    assert port.virtual_model is None and port.read_servos() is None and port.servo_stream() is None
    port.write(b"PING\n")
    assert port.read(5) == b"PING\n"  # bytes go to the wrapped port
    port.close()


def test_the_host_uses_only_the_board_interface():
    tree = ast.parse((ARM / "link" / "_arm.py").read_text())
    probes = [node.lineno for node in ast.walk(tree) if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == "hasattr"]
    assert probes == [], f"hasattr in labkit/arm/link/_arm.py at lines {probes}"
    names = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)}
    assert not names & {"read_bus", "board", "emulator", "physics", "stream_rows", "driver"}


def _classes(package):
    for info in pkgutil.iter_modules(package.__path__):
        module = importlib.import_module(f"{package.__name__}.{info.name}")
        yield from (c for _, c in inspect.getmembers(module, inspect.isclass) if c.__module__ == module.__name__)


def test_no_bus_class_inherits_a_simulator():
    classes = list(_classes(labkit.arm.bus))
    assert BusBoard in classes
    for cls in classes:
        assert not issubclass(cls, (VirtualBoard, SimSerial)), cls
    # the real-hardware port (dynamixel://, feetech://) is not a simulated port either
    assert not issubclass(BusSerial, SimSerial) and issubclass(BusSerial, BoardSerial)
    # and by its source: no bus module names the virtual board or the sim:// port as a base
    for path in (ARM / "bus").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                bases = {ast.unparse(b) for b in node.bases}
                assert not bases & {"VirtualBoard", "SimSerial", "Serial"}, (path.name, node.name, bases)


# -- a new bus protocol: one codec module, one registry entry -------------------------------------------------

OFFSET = 100  # the toy servo's control table: Dynamixel's, 100 bytes further up


def _toy_codec():
    """A bus codec module written here: Protocol 2.0 framing, its own control table, model and units."""
    dxl = bus_module("dynamixel")
    toy = types.ModuleType("toy_bus_codec")
    toy.PROTOCOL = "toy"
    toy.TABLE = {name: (address + OFFSET, size) for name, (address, size) in dxl.TABLE.items()}
    toy.STATE = (dxl.STATE[0] + OFFSET, dxl.STATE[1])
    toy.MODEL = 4242
    toy.CURRENT_UNIT = 1e-3
    toy.TORQUE_CONSTANT = 1.0
    for name in ("HARDWARE_ERRORS", "ALERT", "INSTRUCTIONS", "BROADCAST", "ADDRESS_BYTES", "SIGN_MAGNITUDE", "GAINS",
                 "DEFAULT_GAINS", "MOTOR", "GRIPPER_MODE", "CURRENT_LIMIT",
                 "encode", "decode", "status", "ping_reply"):
        setattr(toy, name, getattr(dxl, name))

    class ToyDriver(dxl.Driver):
        protocol = "toy"
        table = toy.TABLE
        state = toy.STATE
        current_unit = toy.CURRENT_UNIT

    toy.Driver = ToyDriver
    return toy


@pytest.fixture
def toy_bus(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "toy_bus_codec", _toy_codec())
    monkeypatch.setitem(BUSES, "toy", "toy_bus_codec")  # the registry entry
    robot = tmp_path / "toy_arm.toml"
    robot.write_text(Path(BUS_ROBOTS["dynamixel"]).read_text().replace('protocol = "dynamixel"', 'protocol = "toy"')
                     .replace('name = "omx_test"', 'name = "toy_arm"'))
    yield str(robot)
    sys.modules.pop("labkit.arm.urlhandler.protocol_toy", None)


def test_a_new_bus_protocol_runs_end_to_end_on_a_virtual_bus(toy_bus):
    with Arm(toy_bus, f"sim://{toy_bus}?bus=toy&clock=lockstep") as arm:
        emu = arm.port.emulator
        assert emu.bus.PROTOCOL == "toy" and arm.port.board.driver.protocol == "toy"
        assert emu.get(11, "model_number") == 4242
        target = np.radians([30.0, 20.0, -10.0, 15.0])
        arm.move_joints(target, wait=True)
        assert np.allclose(arm.read_joints(), target, atol=math.radians(0.5))
        assert np.allclose(arm.virtual_model.shaft_q, target, atol=math.radians(0.5))
        load = arm.read_load()
        assert load.shape == (4,) and abs(load[1]) > 0.05
        df = arm.stream(0.2, hz=50)
        assert len(df) >= 9 and np.allclose(df["q_shoulder"], target[1], atol=math.radians(0.5))
        goals = [p for p in emu.packets if p[0] == "sync write"]
        assert goals and all(p[2][0] | p[2][1] << 8 == 116 + OFFSET for p in goals)  # the toy's goal_position
        assert emu.rejected == []


def test_a_new_bus_protocol_is_a_url_scheme(toy_bus):
    register()
    port = serial.serial_for_url("toy:///dev/null", do_not_open=True)
    assert isinstance(port, BusSerial)
    with pytest.raises(serial.SerialException, match="expected the robot file"):
        port.open()
    with pytest.raises(serial.SerialException, match="bus one of dynamixel, feetech, toy"):
        serial.serial_for_url(f"sim://{toy_bus}?bus=nobus")


def test_a_robot_file_may_name_any_protocol_and_opening_it_lists_the_known_ones(tmp_path):
    from labkit.arm.bus import open_bus_board
    from labkit.exceptions import OptionError
    from labkit.robot import Robot

    path = tmp_path / "herkulex_arm.toml"
    path.write_text(Path(BUS_ROBOTS["dynamixel"]).read_text().replace('protocol = "dynamixel"', 'protocol = "herkulex"'))
    robot = Robot.load(str(path))  # the robot layer checks the name's form only
    assert robot.bus.protocol == "herkulex"
    with pytest.raises(OptionError, match="one of dynamixel, feetech, got 'herkulex'"):
        open_bus_board(robot, "/dev/null")
    with pytest.raises(OptionError, match="protocol = 'feetech' for a feetech bus, got \\[bus\\] protocol = 'herkulex'"):
        open_bus_board(robot, "/dev/null", protocol="feetech")
