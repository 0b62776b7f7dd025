"""pyserial URL handlers of labkit (``sim://`` virtual arm, ``simavr://`` firmware simulator,
``<bus>://`` servo buses: ``dynamixel://``, ``feetech://``, every protocol of :data:`labkit.arm.bus.BUSES`).

pyserial looks for ``protocol_<scheme>`` modules in the packages listed in
``serial.protocol_handler_packages``; :func:`register` adds this package once and names
:mod:`labkit.arm.urlhandler.bus_port` as the ``protocol_<protocol>`` module of every bus protocol of the
registry, so that a new bus protocol needs no handler module of its own.
"""

import sys

import serial


def register():
    """Make ``serial.serial_for_url`` understand labkit's URL schemes (idempotent)."""
    from labkit.arm.bus import BUSES
    from labkit.arm.urlhandler import bus_port

    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
    for protocol in BUSES:
        sys.modules.setdefault(f"{__name__}.protocol_{protocol}", bus_port)
