"""Robot description: Denavit-Hartenberg links, servo calibration, robot files.

A robot is data: a frozen :class:`Robot` of :class:`Link` rows loaded from a
small TOML file (format documented in ``docs/robot-files.md``). Lengths are
stored in metres and angles in radians whatever units the file declares.
Convenience methods (``robot.fk(q)``) delegate to the pure functions of
:mod:`labkit.kinematics` and :mod:`labkit.kinematics`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.exceptions import JointLimitError, OptionError, RobotError
from labkit.robot._fields import _check_channel, _check_direction, _check_integer, _check_stall_torque, _finite, _limit_pair
from labkit.robot._inertia import LinkInertia, Motor

__all__ = [
    "Convention",
    "JointType",
    "ServoCalibration",
    "Gripper",
    "BusGripper",
    "BusServo",
    "Bus",
    "Link",
    "LinkInertia",
    "Motor",
]

#: what a ``protocol`` name looks like: lower-case letters, digits and ``_``, starting with a letter (which
#: protocols exist is :data:`labkit.arm.bus.BUSES`, checked when a bus is opened)
_PROTOCOL_NAME = re.compile(r"[a-z][a-z0-9_]{0,31}")

FORMAT = "labkit-robot/1"
_LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
_ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}


def _unit_scale(units, unit, name):
    """The SI factor of ``unit`` in ``units`` (``_LENGTH_UNITS`` or ``_ANGLE_UNITS``), else an OptionError."""
    if not isinstance(unit, str) or unit not in units:
        raise OptionError(f"expected {name} one of {sorted(units)}, got {unit!r}")
    return units[unit]


class Convention(str, Enum):
    """Denavit-Hartenberg convention of a robot file.

    ``STANDARD``: ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``.
    ``MODIFIED`` (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``;
    a modified-DH row ``i`` stores ``a_{i-1}`` and ``alpha_{i-1}``.
    """

    STANDARD = "standard"
    MODIFIED = "modified"


class JointType(str, Enum):
    """Kind of joint: revolute (variable theta) or prismatic (variable d)."""

    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"


@dataclass(frozen=True)
class ServoCalibration:
    """Map between a DH joint value and a hobby-servo command.

    ``servo_angle = zero + direction * q`` (revolute, radians) and the pulse
    width is linear in the servo angle over ``angle_range -> pulse_range``.

    Attributes
    ----------
    channel : int
        Servo channel / pin index on the board (0-5).
    zero : float
        Servo angle at ``q = 0`` [rad] (prismatic: [m]).
    direction : int
        +1 or -1.
    angle_range : tuple of float
        Servo angle range (min, max) [rad] covered by ``pulse_range``.
    pulse_range : tuple of float
        Pulse widths (min, max) [us] for ``angle_range``.
    feedback_adc : tuple of float
        ADC counts (0-1023 on a 5 V Uno) read on the servo's potentiometer tap
        at the two ends of ``angle_range`` (default 0.5 V -> 4.5 V).
    stall_torque : float or None
        The servo's stall (holding) torque from its datasheet [N m], or None if unknown.
    no_load_speed : float or None
        The servo's no-load speed from its datasheet [rad/s], the most the virtual arm moves it at; None if unknown.

    An RC linear servo (a prismatic joint's, e.g. an Actuonix L16-R) has metres for radians: ``angle_range``
    is its rod's positions at the ends of ``pulse_range`` (its stroke), ``no_load_speed`` [m/s].
    """

    channel: int
    zero: float = 0.0
    direction: int = 1
    angle_range: tuple = (0.0, math.pi)
    pulse_range: tuple = (500.0, 2500.0)
    feedback_adc: tuple = (102.3, 920.7)
    stall_torque: float | None = None
    no_load_speed: float | None = None

    def __post_init__(self):
        owner = "ServoCalibration"
        _check_stall_torque(owner, self)
        if self.no_load_speed is not None:
            v = _finite(owner, "no_load_speed", self.no_load_speed)
            if not v > 0:
                raise RobotError(f"{owner}: field 'no_load_speed': expected a speed > 0, got {v:g}", "no_load_speed")
            object.__setattr__(self, "no_load_speed", v)
        _check_channel(owner, "channel", self.channel)
        _check_direction(owner, self.direction)
        object.__setattr__(self, "zero", _finite(owner, "zero", self.zero))
        for field in ("angle_range", "pulse_range", "feedback_adc"):
            pair = _limit_pair(owner, field, getattr(self, field))
            if not all(math.isfinite(v) for v in pair):
                raise RobotError(f"{owner}: field '{field}': expected [lower, upper], got {getattr(self, field)!r}", field)
            object.__setattr__(self, field, pair)

    def servo_angle(self, q):
        """Servo angle [rad] for joint value ``q`` [rad].

        Parameters
        ----------
        q : array_like, shape (...)
            Joint values [rad].

        Returns
        -------
        ndarray, shape (...)
            Servo angles ``zero + direction * q`` [rad].
        """
        return self.zero + self.direction * np.asarray(q, dtype=float)

    def joint_from_servo_angle(self, angle):
        """Joint value [rad] for servo angle ``angle`` [rad].

        Parameters
        ----------
        angle : array_like, shape (...)
            Servo angles [rad].

        Returns
        -------
        ndarray, shape (...)
            Joint values ``(angle - zero) * direction`` [rad].
        """
        return (np.asarray(angle, dtype=float) - self.zero) * self.direction

    def pulse_us(self, q):
        """Pulse width [us] commanding joint value ``q``.

        Parameters
        ----------
        q : array_like, shape (...)
            Joint values [rad].

        Returns
        -------
        ndarray, shape (...)
            Pulse widths [us], linear in the servo angle over ``pulse_range``.

        Raises
        ------
        JointLimitError
            If the servo angle falls outside ``angle_range``.
        """
        a = self.servo_angle(q)
        lo, hi = self.angle_range
        if np.any(a < lo - 1e-9) or np.any(a > hi + 1e-9):
            raise JointLimitError(
                f"servo channel {self.channel}: joint value(s) {np.degrees(q)} deg give servo "
                f"angle(s) {np.degrees(a)} deg outside the servo range "
                f"[{math.degrees(lo):.1f}, {math.degrees(hi):.1f}] deg",
                joint=None,
            )
        return self.pulse_from_servo_angle(a)

    def pulse_from_servo_angle(self, angle):
        """Pulse widths at servo angles (or an RC linear servo's positions), not range-checked.

        Parameters
        ----------
        angle : array_like, shape (...)
            Servo angles [rad], or positions along an RC linear servo's stroke [m].

        Returns
        -------
        ndarray, shape (...)
            Pulse widths [us], linear in ``angle`` over ``angle_range`` -> ``pulse_range``.
        """
        lo, hi = self.angle_range
        p0, p1 = self.pulse_range
        return p0 + (np.asarray(angle, dtype=float) - lo) / (hi - lo) * (p1 - p0)

    def joint_from_adc(self, counts):
        """Joint value [rad] sensed from feedback ADC ``counts``.

        Parameters
        ----------
        counts : array_like, shape (...)
            Feedback ADC readings [counts] (may be fractional, e.g. averages).

        Returns
        -------
        ndarray, shape (...)
            Joint values [rad], linear in the counts over ``feedback_adc``.
        """
        lo, hi = self.angle_range
        c0, c1 = self.feedback_adc
        a = lo + (np.asarray(counts, dtype=float) - c0) / (c1 - c0) * (hi - lo)
        return self.joint_from_servo_angle(a)

    def adc_from_joint(self, q):
        """Feedback ADC counts (float) for joint value ``q`` [rad].

        Parameters
        ----------
        q : array_like, shape (...)
            Joint values [rad].

        Returns
        -------
        ndarray, shape (...)
            Expected feedback readings [counts], not rounded.
        """
        lo, hi = self.angle_range
        c0, c1 = self.feedback_adc
        return c0 + (self.servo_angle(q) - lo) / (hi - lo) * (c1 - c0)

    def joint_from_pulse(self, pulse_us):
        """Joint value [rad] commanded by ``pulse_us`` [us].

        Parameters
        ----------
        pulse_us : array_like, shape (...)
            Pulse widths [us].

        Returns
        -------
        ndarray, shape (...)
            Joint values [rad] (not checked against the servo range).
        """
        lo, hi = self.angle_range
        p0, p1 = self.pulse_range
        a = lo + (np.asarray(pulse_us, dtype=float) - p0) / (p1 - p0) * (hi - lo)
        return self.joint_from_servo_angle(a)


@dataclass(frozen=True)
class Gripper:
    """A gripper servo: channel and the pulse widths that open and close it [us]."""

    channel: int
    open_us: float
    closed_us: float

    def __post_init__(self):
        _check_channel("Gripper", "channel", self.channel)
        for field in ("open_us", "closed_us"):
            object.__setattr__(self, field, _finite("Gripper", field, getattr(self, field)))
            if getattr(self, field) <= 0:
                raise RobotError(f"Gripper: field '{field}': expected a pulse width > 0 us, got {getattr(self, field):g}",
                                 field)
        if self.open_us == self.closed_us:
            raise RobotError(f"Gripper: field 'closed_us': expected a pulse other than open_us = {self.open_us:g} us "
                             f"(the gripper would never move), got {self.closed_us:g}", "closed_us")


@dataclass(frozen=True)
class BusServo:
    """A joint driven by a smart servo on a bus (Dynamixel, Feetech): its id and the tick <-> radian map.

    ``ticks = zero + direction * q * resolution / (2 pi)``: the joint angle is 0 rad at tick
    ``zero`` (robot-file table ``bus = { id = 11, zero = 2048, direction = 1 }``).

    Attributes
    ----------
    id : int
        Servo id on the bus (0..252).
    zero : float
        Position [ticks] at ``q = 0``.
    direction : int
        +1 or -1 (the servo's positive sense against the joint's).
    resolution : int
        Ticks per turn (the ``[bus]`` table's ``resolution``; 4096 on an XM430 and an STS3215).
    stall_torque : float or None
        The servo's stall (holding) torque from its datasheet [N m], or None if unknown.
    torque_constant : float or None
        Output torque per ampere of present current from its datasheet (stall torque over stall
        current) [N m/A], or None if unknown: how a bus servo's current reads as a joint torque.

    Examples
    --------
    >>> s = BusServo(id=11, zero=2048, direction=-1, resolution=4096)
    >>> int(s.ticks(math.pi / 2))
    1024
    >>> float(s.joint(1024)) == math.pi / 2
    True
    """

    id: int
    zero: float = 2048.0
    direction: int = 1
    resolution: int = 4096
    stall_torque: float | None = None
    torque_constant: float | None = None

    def __post_init__(self):
        owner = "BusServo"
        _check_stall_torque(owner, self)
        if self.torque_constant is not None:
            kt = _finite(owner, "torque_constant", self.torque_constant)
            if not kt > 0:
                raise RobotError(f"{owner}: field 'torque_constant': expected a torque constant > 0 N m/A, got {kt:g}",
                                 "torque_constant")
            object.__setattr__(self, "torque_constant", kt)
        _check_integer(owner, "id", self.id, 0, 252)
        _check_direction(owner, self.direction)
        _check_integer(owner, "resolution", self.resolution, 16, 1_048_576, " ticks/turn")
        object.__setattr__(self, "zero", _finite(owner, "zero", self.zero))

    def ticks(self, q):
        """Servo position [ticks, rounded to integers] for joint values ``q`` [rad].

        Parameters
        ----------
        q : array_like, shape (...)
            Joint values [rad].

        Returns
        -------
        ndarray of int, shape (...)

        Raises
        ------
        JointLimitError
            A value that is not finite or many turns away (no servo position, nor a 64-bit integer).
        """
        with np.errstate(over="ignore", invalid="ignore"):  # a value past float range is refused below, not warned
            t = self.zero + self.direction * np.asarray(q, dtype=float) * self.resolution / (2 * math.pi)
        if not np.all(np.abs(t) < 2.0 ** 62):
            raise JointLimitError(f"BusServo {self.id}: expected finite joint values within a few turns, got "
                                  f"{float(np.ravel(q)[~(np.abs(np.ravel(t)) < 2.0 ** 62)][0]):g} rad")
        return np.rint(t).astype(np.int64)

    def joint(self, ticks):
        """Joint values [rad] for servo positions ``ticks``.

        Parameters
        ----------
        ticks : array_like, shape (...)
            Servo positions [ticks].

        Returns
        -------
        ndarray, shape (...)
        """
        return (np.asarray(ticks, dtype=float) - self.zero) * self.direction * (2 * math.pi) / self.resolution


@dataclass(frozen=True)
class BusGripper:
    """A gripper driven by a servo on the arm's bus: its servo, where it opens and closes, and its grip limit.

    Robot-file table ``[gripper]`` with ``bus = { id = 15, zero = 2048, direction = 1 }``, ``open``,
    ``closed`` (the servo's angle, in the file's angle unit) and ``max_torque`` [N m].

    Attributes
    ----------
    servo : BusServo
        The gripper's servo (id, zero, direction, resolution).
    open : float
        Servo angle of the open gripper [rad].
    closed : float
        Servo angle of the closed gripper [rad].
    max_torque : float or None
        The torque the gripper may squeeze with [N m]: the servo's current limit (Dynamixel current-based
        position mode) or torque limit (Feetech); ``None``: the servo's own limit.

    Examples
    --------
    >>> g = BusGripper(BusServo(15), open=-0.67, closed=0.67, max_torque=0.5)
    >>> int(g.servo.ticks(g.open))
    1611
    """

    servo: "BusServo"
    open: float
    closed: float
    max_torque: float | None = None

    def __post_init__(self):
        owner = "BusGripper"
        if not isinstance(self.servo, BusServo):
            raise RobotError(f"{owner}: field 'servo': expected a BusServo, got {self.servo!r}", "servo")
        for field in ("open", "closed"):
            object.__setattr__(self, field, _finite(owner, field, getattr(self, field)))
        if self.open == self.closed:
            raise RobotError(f"{owner}: field 'closed': expected an angle other than open = {self.open:g} rad "
                             f"(the gripper would never move), got {self.closed:g}", "closed")
        for field in ("open", "closed"):
            if not 0 <= float(self.servo.ticks(getattr(self, field))) <= self.servo.resolution - 1:
                raise RobotError(f"{owner}: field '{field}': expected an angle the servo reaches (0..."
                                 f"{self.servo.resolution - 1} ticks), got {getattr(self, field):g} rad", field)
        if self.max_torque is not None:
            v = _finite(owner, "max_torque", self.max_torque)
            if not v > 0:
                raise RobotError(f"{owner}: field 'max_torque': expected a torque > 0 N m or None, got {v:g}",
                                 "max_torque")
            object.__setattr__(self, "max_torque", v)


@dataclass(frozen=True)
class Bus:
    """A robot file's ``[bus]`` table: which servo bus drives the joints.

    Attributes
    ----------
    protocol : str
        The bus protocol, a key of :data:`labkit.arm.bus.BUSES`: ``"dynamixel"`` (Protocol 2.0) or
        ``"feetech"`` (STS/SCS). The robot layer checks only its form (lower-case letters, digits, ``_``);
        opening the bus checks that labkit has a codec for it.
    baudrate : int
        Bus baud rate [bit/s] the servos are set to (1,000,000 on OpenMANIPULATOR-X and SO-101).
    resolution : int
        Ticks per turn of every servo.
    latency : float or None
        The USB adapter's latency [ms] the status-packet timeouts allow for (``None``: the vendor SDK's
        16 ms, an FTDI adapter's default latency timer; 1 ms once the timer is set to 1 ms).
    """

    protocol: str
    baudrate: int = 1_000_000
    resolution: int = 4096
    latency: float | None = None

    def __post_init__(self):
        if not isinstance(self.protocol, str) or not _PROTOCOL_NAME.fullmatch(self.protocol):
            raise RobotError(f"Bus: field 'protocol': expected a bus protocol name such as 'dynamixel' (lower-case "
                             f"letters, digits, '_'), got {self.protocol!r}", "protocol")
        if isinstance(self.baudrate, bool) or not isinstance(self.baudrate, (int, np.integer)) \
                or not 9600 <= self.baudrate <= 4_500_000:
            raise RobotError(f"Bus: field 'baudrate': expected an integer 9600..4500000 bit/s, got {self.baudrate!r}",
                             "baudrate")
        _check_integer("Bus", "resolution", self.resolution, 16, 1_048_576, " ticks/turn")
        if self.latency is not None:
            if isinstance(self.latency, bool) or not isinstance(self.latency, (int, float, np.integer, np.floating)) \
                    or not 0 <= self.latency <= 1000:
                raise RobotError(f"Bus: field 'latency': expected a number 0..1000 ms or None, got {self.latency!r}",
                                 "latency")
            object.__setattr__(self, "latency", float(self.latency))


@dataclass(frozen=True)
class Link:
    """One Denavit-Hartenberg row.

    The constructor checks what the robot-file loader checks, with the same
    messages (``Link(joint_type="spherical")`` raises :class:`RobotError`
    "expected 'revolute' or 'prismatic', got 'spherical'").

    Attributes
    ----------
    a, alpha : float
        Link length [m] and twist [rad]; ``a_i, alpha_i`` (standard) or
        ``a_{i-1}, alpha_{i-1}`` (modified).
    d : float
        Link offset [m]; for a prismatic joint the constant added to ``q``.
    theta : float
        Joint angle offset [rad]; for a revolute joint the constant added to
        ``q``; for a prismatic joint the fixed angle.
    joint_type : JointType
        Revolute or prismatic (the strings ``"revolute"`` / ``"prismatic"`` are accepted).
    limits : tuple of float
        (lower, upper) limits of ``q`` [rad or m], ``lower < upper``.
    name : str
    servo : ServoCalibration or None
        The hobby servo behind an Arduino board, or None.
    bus : BusServo or None
        The smart servo on a bus (robot-file ``bus = {...}``), or None.
    max_velocity, max_acceleration : float or None
        Joint speed [rad/s or m/s] and acceleration limits (> 0); ``None`` if
        unknown (``inf`` is taken as ``None``).
    flip : bool
        The joint variable enters the chain negated (roboticstoolbox's ``flip``):
        ``theta_i = -q_i + theta`` (revolute) or ``d_i = -q_i + d`` (prismatic).
        Limits, speeds and servo calibration stay in terms of ``q``.
    inertial : LinkInertia or None
        Mass, centre of mass and inertia of the link this joint moves, in frame i
        (robot-file keys ``mass``, ``com``, ``inertia``); None: a massless link.
    motor : Motor or None
        Rotor inertia, gear ratio and friction of the joint's drive (robot-file ``motor``); None: none.

    Raises
    ------
    RobotError
        A field the robot-file loader would reject.

    Examples
    --------
    >>> Link(a=0.1, joint_type="revolute", flip=True).flip
    True
    """

    a: float = 0.0
    alpha: float = 0.0
    d: float = 0.0
    theta: float = 0.0
    joint_type: JointType = JointType.REVOLUTE
    limits: tuple = (-math.pi, math.pi)
    name: str = ""
    servo: ServoCalibration | None = None
    max_velocity: float | None = None
    max_acceleration: float | None = None
    flip: bool = False
    bus: BusServo | None = None
    inertial: LinkInertia | None = None
    motor: Motor | None = None

    def __post_init__(self):
        owner = f"Link {self.name!r}" if self.name else "Link"
        jt = self.joint_type
        if not isinstance(jt, JointType):
            if jt not in ("revolute", "prismatic"):
                raise RobotError(
                    f"{owner}: field 'type': expected 'revolute' or 'prismatic', got {jt!r}", "type"
                )
            object.__setattr__(self, "joint_type", JointType(jt))
        for field in ("a", "alpha", "d", "theta"):
            object.__setattr__(self, field, _finite(owner, field, getattr(self, field)))
        object.__setattr__(self, "limits", _limit_pair(owner, "limits", self.limits))
        for field in ("max_velocity", "max_acceleration"):
            v = getattr(self, field)
            if v is None or v == math.inf:  # no limit: one meaning, None
                object.__setattr__(self, field, None)
                continue
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)) \
                    or math.isnan(v) or v == -math.inf:
                raise RobotError(f"{owner}: field '{field}': expected a finite number, got {v!r}", field)
            if not v >= 1e-6:  # the robot-file loader's _MIN_LIMIT: 1e-320 is a typo, not a speed
                raise RobotError(f"{owner}: field '{field}': expected a positive number >= 1e-06, got {v!r}", field)
            object.__setattr__(self, field, float(v))
        if not isinstance(self.name, str) or not self.name.isprintable():
            raise RobotError(f"{owner}: field 'name': expected a string of printable characters, got {self.name!r}",
                             "name")
        if self.servo is not None and not isinstance(self.servo, ServoCalibration):
            raise RobotError(
                f"{owner}: field 'servo': expected a ServoCalibration or None, got {self.servo!r}", "servo"
            )
        if self.bus is not None and not isinstance(self.bus, BusServo):
            raise RobotError(f"{owner}: field 'bus': expected a BusServo or None, got {self.bus!r}", "bus")
        if not isinstance(self.flip, (bool, np.bool_)):
            raise RobotError(f"{owner}: field 'flip': expected true or false, got {self.flip!r}", "flip")
        object.__setattr__(self, "flip", bool(self.flip))
        for field, cls in (("inertial", LinkInertia), ("motor", Motor)):
            if getattr(self, field) is not None and not isinstance(getattr(self, field), cls):
                raise RobotError(f"{owner}: field '{field}': expected a {cls.__name__} or None, "
                                 f"got {getattr(self, field)!r}", field)

    @property
    def is_revolute(self):
        """Whether the joint is revolute (its variable is an angle) [bool]."""
        return self.joint_type is JointType.REVOLUTE
