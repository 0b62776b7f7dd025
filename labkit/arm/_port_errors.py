"""Errors of labkit's serial ports (``sim://``, ``simavr://`` and the simavr harness's port).

Each is a :class:`labkit.exceptions.LabkitError` (the message says what was expected and what was
received) and also pyserial's ``SerialException``, which callers of ``serial.serial_for_url`` catch.
"""

from serial.serialutil import PortNotOpenError, SerialException

from labkit.exceptions import DeviceError, OptionError

__all__ = ["PortURLError", "PortError", "PortClosedError"]


class PortURLError(OptionError, SerialException):
    """A ``sim://`` or ``simavr://`` URL that cannot be opened: another scheme, an unknown option, a bad value.

    An :class:`labkit.exceptions.OptionError` (the message names the option, what was expected and what
    was received) that is also pyserial's ``SerialException``, which callers of
    ``serial.serial_for_url`` catch.
    """


class PortError(DeviceError, SerialException):
    """A simulated port failed: its board or simulator could not be started, or a read cannot return.

    A :class:`labkit.exceptions.DeviceError` that is also pyserial's ``SerialException``.
    """


class PortClosedError(PortError, PortNotOpenError):
    """A closed ``sim://`` port was used (also pyserial's ``PortNotOpenError``).

    Parameters
    ----------
    port : str
        The port's URL.
    """

    def __init__(self, port):
        SerialException.__init__(self, f"{port}: expected an open port, got a closed one (open it first)")
