"""The bus protocols labkit drives: one codec module per protocol, one entry here.

:data:`BUSES` is data: a bus protocol (the robot file's ``[bus] protocol``, the URL scheme
``<protocol>://``, the ``sim://...?bus=<protocol>`` option) -> the module that holds everything the bus
fixes for both ends. A codec module defines:

- ``PROTOCOL`` (its key here); ``TABLE`` (control-table field -> ``(address, size)``), ``STATE`` (the ``(address, size)`` a
  sync read of the state takes), ``MODEL`` (the model number virtual servos report), ``CURRENT_UNIT``
  [A per LSB], ``TORQUE_CONSTANT`` [N m / A], ``HARDWARE_ERRORS`` (bit -> name), ``ALERT`` (the status
  error bit that means "read the hardware error", or ``None``), ``INSTRUCTIONS`` (code -> ``"ping"``,
  ``"read"``, ``"write"``, ``"sync read"``, ``"sync write"``), ``BROADCAST``, ``ADDRESS_BYTES``,
  ``SIGN_MAGNITUDE``; ``GAINS`` (``kp``/``ki``/``kd`` -> ``(field, largest value, factor)`` of the servo's
  position loop), ``DEFAULT_GAINS``, ``MOTOR`` (stall torque, no-load speed, gear ratio, full-scale loop output,
  rotor inertia: the virtual servo's loop, :mod:`labkit.arm.bus._servo_loop`), ``GRIPPER_MODE`` and
  ``CURRENT_LIMIT`` (the gripper's operating mode and largest goal current, ``None`` where the servo has none);
  ``SIGN_MAGNITUDE``; optionally the homing offset, ``HOMING_OFFSET`` (``(address, size)``), ``HOMING_SIGN``
  (present = actual + sign * offset), ``HOMING_LIMIT``, ``HOMING_SIGN_BIT`` and ``EEPROM_LOCK`` (what a guided
  calibration writes to re-home a servo; without them a range across the encoder's seam is an error);
- ``encode(servo_id, instruction, params, error=None)``, ``decode(buffer)``, ``status(servo_id, error,
  params)`` and ``ping_reply(model)``: the packet codec the virtual bus (:class:`BusEmulator`) parses
  and answers with;
- ``Driver``: its :class:`BusDriver` subclass, the host side through the vendor SDK.

Adding a bus is that module and one entry in :data:`BUSES`; the board (:class:`BusBoard`), the
virtual bus, the URL handlers and :class:`labkit.arm.Arm` find it here. The robot-file loader, a layer
below, checks only that ``[bus] protocol`` is a name; opening the bus (:func:`bus_module`) checks that
it is one of these.
"""

from __future__ import annotations

import importlib

from labkit.exceptions import OptionError

__all__ = ["BUSES", "bus_module"]

#: bus protocol -> its codec module (imported on first use)
BUSES = {"dynamixel": "labkit.arm.bus._dynamixel", "feetech": "labkit.arm.bus._feetech"}


def bus_module(protocol):
    """The codec module of bus ``protocol``, or an :class:`OptionError` listing the protocols.

    Parameters
    ----------
    protocol : str
        A key of :data:`BUSES`.

    Returns
    -------
    module

    Raises
    ------
    OptionError
        ``protocol`` is not a key of :data:`BUSES`.

    Examples
    --------
    >>> bus_module("feetech").PROTOCOL
    'feetech'
    """
    if protocol not in BUSES:
        raise OptionError(f"expected a bus protocol labkit has a codec for, one of {', '.join(BUSES)}, "
                          f"got {protocol!r}")
    return importlib.import_module(BUSES[protocol])
