"""pyserial URL handlers of labkit (``sim://`` virtual arm, ``simavr://`` firmware simulator,
``dynamixel://`` and ``feetech://`` servo buses).

pyserial looks for ``protocol_<scheme>`` modules in the packages listed in
``serial.protocol_handler_packages``; :func:`register` adds this package once.
"""

import serial


def register():
    """Make ``serial.serial_for_url`` understand labkit's URL schemes (idempotent)."""
    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
