"""The pyserial URL handlers (``sim://``, ``simavr://``) raise labkit errors that are also pyserial's.

Every error labkit raises derives from :class:`labkit.exceptions.LabkitError` and says what was
expected and what was received; callers of ``serial.serial_for_url`` still catch
``serial.SerialException`` (and ``serial.PortNotOpenError`` for a closed port).
"""

from __future__ import annotations

import pytest
import serial

from labkit.arm.urlhandler import register
from labkit.arm import PortClosedError, PortError, PortURLError
from labkit.arm.urlhandler.protocol_simavr import parse_url as parse_simavr_url
from labkit.exceptions import DeviceError, LabkitError, OptionError

register()


@pytest.mark.parametrize("url, message", [
    ("sim://?colour=red", r"unknown option 'colour'; valid options: clock, time_scale, queue, calibrated, seed"),
    ("sim://?clock=fast", r"expected clock one of realtime, lockstep, got 'fast'"),
    ("sim://?time_scale=0", r"expected time_scale > 0, got 0"),
    ("sim://?calibrated=2", r"expected calibrated=0 or 1, got '2'"),
    ("sim://?seed=x", r"option 'seed': expected an integer, got 'x'"),
    ("sim://?queue=1.5", r"option 'queue': expected an integer, got '1.5'"),
    ("sim://?deadband=abc", r"option 'deadband': expected a number, got 'abc'"),
    ("sim://?zero_offsets=0,x,0", r"option 'zero_offsets': expected numbers, got '0,x,0'"),
    ("sim://?time_scale=fast", r"option 'time_scale': expected a number, got 'fast'"),
    ("sim://no_such_robot", r"unknown robot; expected a file path or one of: al5d, arduino_arm_3dof"),
])
def test_a_bad_sim_url_raises_a_labkit_option_error_that_is_a_serial_exception(url, message):
    with pytest.raises(LabkitError, match=message) as info:
        serial.serial_for_url(url, timeout=0.1)
    err = info.value
    assert type(err) is PortURLError
    assert isinstance(err, OptionError) and isinstance(err, ValueError)
    assert isinstance(err, serial.SerialException)  # what pyserial callers catch
    assert str(err).startswith(url)  # names the URL


def test_sim_parse_url_refuses_another_scheme_with_a_labkit_error():
    from labkit.arm.urlhandler.protocol_sim import parse_url

    with pytest.raises(PortURLError, match=r"expected a URL of the form sim://\[robot\]\?seed=\.\.\., got 'loop://'"):
        parse_url("loop://")


def test_a_closed_sim_port_raises_a_labkit_error_that_is_pyserials_port_not_open_error():
    port = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep", timeout=0.1)
    with pytest.raises(PortError, match="expected a closed port to open, got one already open"):
        port.open()
    port.close()
    for use in (lambda: port.write(b"PING\n"), lambda: port.read(1), lambda: port.in_waiting):
        with pytest.raises(serial.PortNotOpenError) as info:
            use()
        assert isinstance(info.value, PortClosedError) and isinstance(info.value, DeviceError)
        assert "sim://arduino_arm_3dof?clock=lockstep: expected an open port, got a closed one" in str(info.value)


@pytest.mark.parametrize("url, message", [
    ("sim://", r"expected a URL starting with 'simavr://', got 'sim://'"),
    ("simavr://?speed=3", r"unknown option 'speed' in 'simavr://\?speed=3'; valid options: \['clock', 'pace'"),
    ("simavr://?clock=wall", r"option 'clock' in 'simavr://\?clock=wall' must be one of lockstep, realtime, got 'wall'"),
    ("simavr://?seed=1.5", r"option 'seed' in 'simavr://\?seed=1.5' must be an integer, got '1.5'"),
    ("simavr://?pace=-1", r"option 'pace' in 'simavr://\?pace=-1' must be >= 0, got -1"),
    ("simavr://?pace=1&clock=lockstep", r"clock=lockstep .* cannot also be paced \(pace=1\)"),
])
def test_a_bad_simavr_url_raises_a_labkit_option_error_that_is_a_serial_exception(url, message):
    with pytest.raises(LabkitError, match=message) as info:
        parse_simavr_url(url)
    assert type(info.value) is PortURLError and isinstance(info.value, serial.SerialException)


def test_simavr_open_failures_are_labkit_errors_before_the_simulator_runs():
    # an unknown robot for the arm model: a bad URL (checked before the simulator starts)
    with pytest.raises(PortURLError, match=r"could not set up the arm model for 'simavr://\?physics=nope'.*unknown robot"):
        serial.serial_for_url("simavr://?physics=nope", timeout=0.1)
    # a firmware ELF that does not exist: the simulator cannot start (a device error)
    with pytest.raises(PortError, match=r"could not start the firmware simulator .*does not exist") as info:
        serial.serial_for_url("simavr:///no/such/firmware.elf", timeout=0.1)
    assert isinstance(info.value, DeviceError) and isinstance(info.value, serial.SerialException)
