"""The gripper servo of a bus arm: opened, closed and positioned with a grip limit, on real and virtual buses.

A bus arm's gripper is one more servo on the bus (robot file ``[gripper]`` with ``bus = { id, zero,
direction }``, ``open``, ``closed`` [rad] and ``max_torque`` [N m], :class:`labkit.robot.BusGripper`).
Its grip is limited where the servo has a limit: a Dynamixel runs in current-based position mode
(Operating Mode(11) = 5, as the OpenMANIPULATOR-X gripper) with Goal Current(102) as the limit
(``max_torque / TORQUE_CONSTANT``, at most Current Limit(38)); a Feetech STS3215 in position mode
with Torque_Limit(48) (per mille of its stall torque). :func:`limit_register` is that rule, written
once: the host writes with it and the virtual bus (:class:`VirtualGripper`) reads the limit back with
:func:`limit_torque`.

:class:`GripperServo` is what a :class:`BusBoard` holds for it: it pings the servo, sets its mode and
limit (torque off for the mode, an EEPROM field on a Dynamixel), makes the present position the
goal, turns torque on, checks every position against the robot file's travel and every limit
against the servo's, and on close turns torque off and writes the mode and limit back.

Every gripper write is a confirmed write, the same one the joints' goals, torque and gains go through
(:func:`labkit.arm.bus._confirm.write_confirmed`): written, read back and written again until the servo
holds the value, else a :class:`BusFault` naming the servo (``servo 15 (gripper)``), what it was sent
and what it holds. A gripper move therefore never returns while the servo's goal or grip limit differs
from what the host sent. On close the same write is tried a few times without raising
(:func:`~labkit.arm.bus._confirm.write_unconfirmed`), as the joints' torque off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from labkit.exceptions import OptionError
from labkit.arm.bus._confirm import write_confirmed, write_unconfirmed
from labkit.arm.bus._driver import QUIET_TRIES
from labkit.arm.bus._gains import read_field
from labkit.arm.bus._registry import bus_module

__all__ = ["GripperState", "GripperServo", "VirtualGripper", "limit_register", "limit_torque"]


@dataclass(frozen=True)
class GripperState:
    """One read of a bus gripper.

    Attributes
    ----------
    position : float
        Present servo angle [rad] (``open`` .. ``closed`` of the robot file).
    goal : float
        Goal angle [rad].
    current : float
        Present current [A] (signed; its magnitude near the limit means the jaws squeeze something).
    """

    position: float
    goal: float
    current: float


def limit_register(bus, torque):
    """The register and value that limit a gripper servo of bus module ``bus`` to ``torque`` [N m].

    Parameters
    ----------
    bus : module
        The bus's codec module.
    torque : float
        Grip limit [N m], > 0.

    Returns
    -------
    field : str
        ``"goal_current"`` (Dynamixel, current-based position mode) or ``"torque_limit"`` (Feetech).
    value : int
        Register value, clipped to the servo's range.

    Examples
    --------
    >>> limit_register(bus_module("dynamixel"), 0.5)
    ('goal_current', 104)
    >>> limit_register(bus_module("feetech"), 0.956)
    ('torque_limit', 500)
    """
    if bus.GRIPPER_MODE is not None:
        return "goal_current", int(min(round(torque / bus.TORQUE_CONSTANT / bus.CURRENT_UNIT), bus.CURRENT_LIMIT))
    full = bus.MOTOR["full_scale"]
    return "torque_limit", int(min(round(full * torque / bus.MOTOR["stall_torque"]), full))


def limit_torque(bus, get):
    """The grip limit [N m] a gripper servo's registers set (the inverse of :func:`limit_register`).

    Parameters
    ----------
    bus : module
    get : callable
        ``get(field)`` -> the servo's register value.

    Returns
    -------
    float
    """
    if bus.GRIPPER_MODE is not None:
        amps = get("goal_current" if get("operating_mode") == bus.GRIPPER_MODE else "current_limit")
        return amps * bus.CURRENT_UNIT * bus.TORQUE_CONSTANT
    return get("torque_limit") / bus.MOTOR["full_scale"] * bus.MOTOR["stall_torque"]


class GripperServo:
    """The gripper servo on an open bus (see the module notes).

    Parameters
    ----------
    driver : BusDriver
    gripper : labkit.robot.BusGripper
    """

    def __init__(self, driver, gripper):
        self.driver = driver
        self.gripper = gripper
        self.bus = bus_module(driver.protocol)
        self.id = gripper.servo.id
        self._saved = {}
        self._goal = None
        #: :meth:`start` has reached the servo (what :meth:`close` undoes)
        self.started = False

    def _write(self, field, value):
        """Write ``field`` of the gripper servo, read back until it holds ``value`` (else a :class:`BusFault`)."""
        write_confirmed(self.driver, field, {self.id: int(value)})

    def start(self):
        """Ping the servo, set its mode and limit, hold where it is with torque on.

        Raises
        ------
        BusFault
            The servo does not answer (after the driver's retries), or does not hold a value written to it.
        """
        self.driver.ping(self.id)
        self.started = True
        self._write("torque_enable", 0)
        if self.bus.GRIPPER_MODE is not None:
            self._saved["operating_mode"] = read_field(self.driver, self.id, "operating_mode")
            self._write("operating_mode", self.bus.GRIPPER_MODE)
        field, _ = limit_register(self.bus, 1.0)
        self._saved[field] = read_field(self.driver, self.id, field)
        self.set_limit(self.gripper.max_torque)
        self._write("goal_position", read_field(self.driver, self.id, "present_position"))
        self._write("torque_enable", 1)

    def set_limit(self, torque):
        """Limit the grip to ``torque`` [N m] (``None``: the servo's full limit).

        Parameters
        ----------
        torque : float or None
        """
        stall = self.bus.MOTOR["stall_torque"]
        if torque is None:
            torque = stall
        if isinstance(torque, bool) or not isinstance(torque, (int, float)) or not math.isfinite(torque) \
                or not 0 < torque <= stall:
            raise OptionError(f"gripper servo {self.id}: expected max_torque in (0, {stall:g}] N m (its stall "
                              f"torque), got {torque!r}; nothing was written")
        self._write(*limit_register(self.bus, float(torque)))

    def move(self, position, max_torque=None):
        """Send the gripper to servo angle ``position`` [rad] with a grip limit.

        Parameters
        ----------
        position : float
            Within the robot file's travel (``open`` .. ``closed``) [rad].
        max_torque : float, optional
            Grip limit [N m]; default the robot file's ``max_torque``.

        Raises
        ------
        OptionError
            ``position`` outside the travel or ``max_torque`` outside the servo's range (nothing is written).
        BusFault
            The servo does not hold the limit or the goal after the bounded writes and read-backs.
        """
        g = self.gripper
        lo, hi = sorted((g.open, g.closed))
        if isinstance(position, bool) or not isinstance(position, (int, float)) or not math.isfinite(position) \
                or not lo <= position <= hi:
            raise OptionError(f"gripper servo {self.id}: expected a position in {lo:.4g}..{hi:.4g} rad (open "
                              f"{g.open:.4g}, closed {g.closed:.4g}), got {position!r}; nothing was written")
        torque = g.max_torque if max_torque is None else max_torque
        if torque is not None:
            self.set_limit(torque)  # checked (and refused) before the goal moves
        self._goal = float(position)
        self._write("goal_position", int(g.servo.ticks(position)))

    def read(self):
        """The gripper's present position, goal and current.

        Returns
        -------
        GripperState
        """
        ticks = read_field(self.driver, self.id, "present_position")
        raw = read_field(self.driver, self.id, "present_current")
        if self.bus.SIGN_MAGNITUDE:
            raw = -(raw & 0x7FFF) if raw & 0x8000 else raw
        elif raw >= 0x8000:
            raw -= 0x10000
        s = self.gripper.servo
        goal = self._goal if self._goal is not None else float(s.joint(read_field(self.driver, self.id, "goal_position")))
        return GripperState(float(s.joint(ticks)), goal, raw * self.bus.CURRENT_UNIT)

    def close(self):
        """Torque off and the mode and limit written back, a few tries each, each read back; never raises.

        Returns
        -------
        bool
            Whether the servo holds every value written (``True`` when :meth:`start` never reached the servo).
        """
        if not self.started:
            return True
        try:
            held = True
            for field, value in {"torque_enable": 0, **self._saved}.items():
                held &= not write_unconfirmed(self.driver, field, {self.id: int(value)}, tries=QUIET_TRIES,
                                              read_tries=1, check_error=False)
            return held
        except Exception:  # noqa: BLE001 - best effort: the bus may be what failed
            return False


class VirtualGripper:
    """The virtual bus's gripper servo: the jaw runs to its goal at the servo's no-load speed and stops on an object.

    Parameters
    ----------
    bus : module
        The bus's codec module.
    gripper : labkit.robot.BusGripper
    q0 : float
        Where the jaw rests [rad].

    Attributes
    ----------
    position : float
        Servo angle [rad].
    object : float or None
        Servo angle at which the jaws touch a held object (``None``: nothing between them): a jaw closing
        past it stops there and squeezes with the servo's grip limit.
    current : float
        Present current [A].
    """

    def __init__(self, bus, gripper, q0):
        self.bus = bus
        self.gripper = gripper
        self.position = float(q0)
        self.object = None
        self.current = 0.0
        self.time = 0.0

    def advance_to(self, t, goal, torque_on, limit):
        """Run the jaw to time ``t`` [s] towards ``goal`` [rad] with grip limit ``limit`` [N m].

        Parameters
        ----------
        t : float
        goal : float
        torque_on : bool
        limit : float
        """
        dt, self.time = max(0.0, t - self.time), max(t, self.time)
        if not torque_on:
            self.current = 0.0
            return
        step = self.bus.MOTOR["no_load_speed"] * dt
        c = math.copysign(1.0, self.gripper.closed - self.gripper.open)  # the closing sense
        o = self.object
        blocked = o is not None and (goal - self.position) * c > 0 and self.position * c <= o * c < goal * c
        target = o if blocked else goal
        self.position += max(-step, min(step, target - self.position))
        squeezing = blocked and self.position == o
        sign = math.copysign(1.0, goal - self.position) * self.gripper.servo.direction
        self.current = sign * limit / self.bus.TORQUE_CONSTANT if squeezing else 0.0
