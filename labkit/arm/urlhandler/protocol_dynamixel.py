"""pyserial URL handler ``dynamixel://<device>?baud=...``: a dynamixel servo bus (see :mod:`labkit.arm.urlhandler.bus_port`)."""

from labkit.arm.urlhandler.bus_port import BusSerial as Serial

__all__ = ["Serial"]
