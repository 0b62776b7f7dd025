"""Real-board start-up: listing serial ports (``labkit ports``), auto-detection, and open errors that say what to do."""

import errno
from types import SimpleNamespace

import pytest
import serial

from labkit.arm import Arm, find_ports, list_ports
from labkit.cli import main
from labkit.exceptions import DeviceError


def fake_comports(monkeypatch):
    from serial.tools import list_ports as lp

    ports = [
        SimpleNamespace(device="/dev/ttyS0", vid=None, pid=None, description="n/a", manufacturer=None),
        SimpleNamespace(device="/dev/ttyUSB0", vid=0x1A86, pid=0x7523, description="USB Serial", manufacturer="QinHeng"),
        SimpleNamespace(device="/dev/ttyACM0", vid=0x2341, pid=0x0043, description="Arduino Uno", manufacturer="Arduino"),
    ]
    monkeypatch.setattr(lp, "comports", lambda: ports)


def test_ports_are_listed_arduinos_first(monkeypatch, capsys):
    fake_comports(monkeypatch)
    ports = list_ports()
    assert [p.device for p in ports] == ["/dev/ttyACM0", "/dev/ttyUSB0", "/dev/ttyS0"]
    assert [p.arduino for p in ports] == [True, True, False]
    assert ports[0].usb_id == "2341:0043" and ports[2].usb_id == "-"
    assert find_ports() == ["/dev/ttyACM0", "/dev/ttyUSB0"]
    assert main(["ports"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["*", "/dev/ttyACM0", "2341:0043", "Arduino", "Uno"]
    assert out[2].split()[:3] == ["/dev/ttyS0", "-", "n/a"]
    assert "Arm(robot) without a port takes the first" in out[-1]


def test_an_ftdi_adapter_is_a_possible_bus_adapter_not_an_arduino(monkeypatch, capsys):
    from serial.tools import list_ports as lp

    ports = [SimpleNamespace(device="/dev/ttyUSB1", vid=0x0403, pid=0x6014, description="USB <-> Serial Converter",
                             manufacturer="FTDI"),  # a ROBOTIS U2D2 (FT232H)
             SimpleNamespace(device="/dev/ttyUSB2", vid=0x0403, pid=0x6001, description="FT232R USB UART - Arduino Nano",
                             manufacturer="FTDI")]  # an FTDI clone that says it is an Arduino
    monkeypatch.setattr(lp, "comports", lambda: ports)
    found = list_ports()
    assert [(p.device, p.arduino, p.bus_adapter) for p in found] == [("/dev/ttyUSB2", True, False),
                                                                      ("/dev/ttyUSB1", False, True)]
    assert find_ports() == ["/dev/ttyUSB2"]
    assert main(["ports"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[:2] == ["b", "/dev/ttyUSB1"] and "dynamixel://<port>" in out[-1]
    monkeypatch.setattr(lp, "comports", lambda: ports[:1])
    assert find_ports() == []
    with pytest.raises(DeviceError, match=r"no Arduino-like serial port.*/dev/ttyUSB1 may be a servo-bus adapter.*"
                                          r"'dynamixel:///dev/ttyUSB1'"):
        Arm("arduino_arm_3dof")


def test_auto_detection_opens_the_first_arduino(monkeypatch):
    fake_comports(monkeypatch)
    opened = []

    def fake_open(url, **kw):
        opened.append(url)
        raise serial.SerialException(errno.ENOENT, f"could not open port {url}: No such file or directory")

    monkeypatch.setattr(serial, "serial_for_url", fake_open)
    with pytest.raises(DeviceError, match="ttyACM0.*is the board plugged in"):
        Arm("arduino_arm_3dof")
    assert opened == ["/dev/ttyACM0"]


@pytest.mark.parametrize("code, text, hint", [
    (errno.EBUSY, "[Errno 16] Device or resource busy: '/dev/ttyACM0'", "close the Arduino IDE's serial monitor"),
    (errno.EACCES, "[Errno 13] Permission denied: '/dev/ttyACM0'", "dialout"),
])
def test_busy_and_forbidden_ports_say_what_to_do(monkeypatch, code, text, hint):
    def fake_open(url, **kw):
        raise serial.SerialException(code, f"could not open port {url}: {text}")

    monkeypatch.setattr(serial, "serial_for_url", fake_open)
    with pytest.raises(DeviceError, match=hint):
        Arm("arduino_arm_3dof", "/dev/ttyACM0")


def test_no_ports_at_all(monkeypatch, capsys):
    from serial.tools import list_ports as lp

    monkeypatch.setattr(lp, "comports", lambda: [])
    assert main(["ports"]) == 0
    assert "no serial ports found" in capsys.readouterr().out
    with pytest.raises(DeviceError, match="labkit ports"):
        Arm("arduino_arm_3dof")
