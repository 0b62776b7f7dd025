"""pyserial URL handler ``feetech://<device>?baud=...``: a feetech servo bus (see :mod:`labkit.arm.urlhandler.bus_port`)."""

from labkit.arm.urlhandler.bus_port import BusSerial as Serial

__all__ = ["Serial"]
