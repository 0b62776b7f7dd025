"""The position-loop gains of a bus's servos: read, written within their range, restored on close.

A Dynamixel XM430 keeps its position loop's gains in Position P / I / D Gain (addresses 84, 82,
80, two bytes, 0..16383 each; ROBOTIS e-Manual, XM430-W350 control table); a Feetech STS3215 in
its position-loop P / D / I coefficients (addresses 21, 22, 23, one byte each, 0..254; Feetech's STS
memory table, see ``GAINS`` in :mod:`labkit.arm.bus._feetech` for the sources).
The bus module's ``GAINS`` names the field and the largest value of each gain (``kp``, ``ki``,
``kd``), so that the same code serves every bus. Values are the servo's own register values: a
gain is a setting of the servo's firmware, and only Dynamixel states a conversion
(``labkit.arm.bus._servo_loop`` uses it).

:class:`GainBook` is what a :class:`BusBoard` holds: it reads a servo's gains, checks new ones
against their range before anything is written (an :class:`~labkit.exceptions.OptionError`
naming the servo, its joint, the gain, its register and the range), writes them as confirmed
writes (read back until the servo holds them, :func:`~labkit.arm.bus._confirm.write_confirmed`), and
remembers the values each servo had before labkit first changed them, which :meth:`GainBook.restore`
writes back when the board closes (both registers are RAM on a Dynamixel; on a Feetech labkit
leaves the EEPROM lock alone, so nothing it writes survives a power cycle either way).
"""

from __future__ import annotations

from dataclasses import dataclass

from labkit.exceptions import BusFault, OptionError
from labkit.arm.bus._registry import bus_module
from labkit.arm.bus._adapter import advice
from labkit.arm.bus._confirm import write_confirmed, write_unconfirmed
from labkit.arm.bus._driver import QUIET_TRIES

__all__ = ["ServoGains", "GainBook", "read_field"]

#: the gains, in the order they are shown
GAIN_NAMES = ("kp", "ki", "kd")


@dataclass(frozen=True)
class ServoGains:
    """A servo's position-loop gains as register values (Dynamixel Position P/I/D Gain, Feetech P/I/D coefficient).

    Attributes
    ----------
    kp, ki, kd : int
        Proportional, integral and derivative gain [register value, the servo's own unit].

    Examples
    --------
    >>> ServoGains(800, 0, 0).to_dict()
    {'kp': 800, 'ki': 0, 'kd': 0}
    """

    kp: int
    ki: int
    kd: int

    def to_dict(self):
        """``{"kp": ..., "ki": ..., "kd": ...}``.

        Returns
        -------
        dict of str to int
        """
        return {name: getattr(self, name) for name in GAIN_NAMES}


def read_field(driver, servo_id, field):
    """Read control-table ``field`` of one servo (unsigned), retried ``driver.retries`` times.

    Parameters
    ----------
    driver : BusDriver
    servo_id : int
    field : str
        A key of the driver's control table.

    Returns
    -------
    int

    Raises
    ------
    BusFault
        No intact status packet after the retries.
    """
    address, size = driver.table[field]
    fn = {1: driver.packets.read1ByteTxRx, 2: driver.packets.read2ByteTxRx, 4: driver.packets.read4ByteTxRx}[size]
    for _ in range(driver.retries + 1):
        value, result, error = fn(driver.handler, servo_id, address)
        if result == driver.sdk.COMM_SUCCESS:
            return int(value)
    raise BusFault(f"{driver.name}: reading {field} of {driver.servo(servo_id)} failed after {driver.retries + 1} "
                   f"reads: {driver._comm(result)}; {advice(driver)}")


class GainBook:
    """Position-loop gains of every joint's servo on an open bus (see the module notes).

    Parameters
    ----------
    driver : BusDriver
        The open bus.

    Attributes
    ----------
    saved : dict of int to ServoGains
        Joint index -> the gains its servo had before labkit first wrote them (what :meth:`restore` writes back).
    """

    def __init__(self, driver):
        self.driver = driver
        self.bus = bus_module(driver.protocol)
        self.saved = {}

    def _joint(self, joint):
        names = self.driver.robot.joint_names
        if isinstance(joint, str) and joint in names:
            return names.index(joint)
        if not isinstance(joint, bool) and isinstance(joint, int) and 0 <= joint < len(names):
            return joint
        raise OptionError(f"expected a joint name ({', '.join(names)}) or index 0..{len(names) - 1}, got {joint!r}")

    def read(self, joint):
        """The gains of joint ``joint``'s servo, read from the servo.

        Parameters
        ----------
        joint : int or str
            Joint index or name.

        Returns
        -------
        ServoGains
        """
        servo_id = self.driver.ids[self._joint(joint)]
        return ServoGains(**{name: read_field(self.driver, servo_id, self.bus.GAINS[name][0]) for name in GAIN_NAMES})

    def check(self, joint, **gains):
        """The new gains of joint ``joint`` checked against their ranges (``None``: unchanged), nothing written.

        Parameters
        ----------
        joint : int or str
        **gains : int or None
            ``kp``, ``ki``, ``kd``.

        Returns
        -------
        dict of str to int
            The gains given (not ``None``).

        Raises
        ------
        OptionError
            An unknown gain, or a value that is not a whole number within the servo's range.
        """
        j = self._joint(joint)
        out = {}
        for name, value in gains.items():
            if name not in self.bus.GAINS:
                raise OptionError(f"expected gains among {', '.join(GAIN_NAMES)}, got {name!r}")
            if value is None:
                continue
            field, top, _ = self.bus.GAINS[name]
            whole = not isinstance(value, bool) and isinstance(value, (int, float)) and float(value).is_integer()
            if not whole or not 0 <= value <= top:
                raise OptionError(f"{self.driver.servo(self.driver.ids[j])}: expected {name} ({field}) a whole number "
                                  f"0..{top}, got {value!r}; nothing was written")
            out[name] = int(value)
        return out

    def write(self, joint, **gains):
        """Write new gains to joint ``joint``'s servo (all checked first; the old ones kept for :meth:`restore`).

        Parameters
        ----------
        joint : int or str
        **gains : int or None
            ``kp``, ``ki``, ``kd`` (``None`` or absent: unchanged).

        Returns
        -------
        ServoGains
            The servo's gains now (read back).

        Raises
        ------
        OptionError
            A gain out of its range (nothing is written).
        BusFault
            The bus failed.
        """
        new = self.check(joint, **gains)
        j = self._joint(joint)
        if j not in self.saved:
            self.saved[j] = self.read(j)
        servo_id = self.driver.ids[j]
        for name, value in new.items():  # read back and sent again until the servo holds it
            write_confirmed(self.driver, self.bus.GAINS[name][0], {servo_id: value})
        return self.read(j)

    def restore(self):
        """Write back the gains each servo had before labkit changed them; never raises (on close).

        Returns
        -------
        list of int
            Servo ids whose gains could not be written back.
        """
        failed = []
        for j, gains in sorted(self.saved.items()):
            servo_id = self.driver.ids[j]
            try:  # a few tries each, read back (the same confirmed write as :meth:`write`, not raising)
                lost = [name for name, value in gains.to_dict().items()
                        if write_unconfirmed(self.driver, self.bus.GAINS[name][0], {servo_id: value},
                                             tries=QUIET_TRIES, read_tries=1, check_error=False)]
            except Exception:  # noqa: BLE001 - best effort: the bus may be what failed
                lost = True
            if lost:
                failed.append(servo_id)
        self.saved = {j: g for j, g in self.saved.items() if self.driver.ids[j] in failed}
        return failed
