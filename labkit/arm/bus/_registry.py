"""The bus kinds labkit drives: one module per bus (control table, packet codec, SDK driver), one entry here.

Adding a bus is one new module with the same names (``KIND``, ``TABLE``, ``STATE``, ``encode``,
``decode``, ``status``, ``ping_reply``, its driver class ...) and one entry in :data:`BUSES`.
"""

from __future__ import annotations

from labkit.exceptions import OptionError
from labkit.arm.bus import _dynamixel, _feetech

__all__ = ["BUSES", "bus_module"]

#: bus kind (the robot file's ``[bus] kind``, the URL scheme) -> its module
BUSES = {"dynamixel": _dynamixel, "feetech": _feetech}
#: bus kind -> its host driver class
DRIVERS = {"dynamixel": _dynamixel.DynamixelDriver, "feetech": _feetech.FeetechDriver}


def bus_module(kind):
    """The module of bus ``kind``, or an :class:`OptionError` listing the kinds.

    Parameters
    ----------
    kind : str

    Returns
    -------
    module
    """
    if kind not in BUSES:
        raise OptionError(f"expected a bus kind, one of {', '.join(BUSES)}, got {kind!r}")
    return BUSES[kind]
