"""Robot description: Denavit-Hartenberg links, servo calibration, robot files.

A robot is data: a frozen :class:`Robot` of :class:`Link` rows loaded from a
small TOML file (format documented in ``docs/robot-files.md``). Lengths are
stored in metres and angles in radians whatever units the file declares.
Convenience methods (``robot.fk(q)``) delegate to the pure functions of
:mod:`labkit.kinematics` and :mod:`labkit.kinematics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.exceptions import JointLimitError

__all__ = [
    "Convention",
    "JointType",
    "ServoCalibration",
    "Gripper",
    "Link",
]

FORMAT = "labkit-robot/1"
_LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
_ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}


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
    """

    channel: int
    zero: float = 0.0
    direction: int = 1
    angle_range: tuple = (0.0, math.pi)
    pulse_range: tuple = (500.0, 2500.0)
    feedback_adc: tuple = (102.3, 920.7)

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
        p0, p1 = self.pulse_range
        return p0 + (a - lo) / (hi - lo) * (p1 - p0)

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


@dataclass(frozen=True)
class Link:
    """One Denavit-Hartenberg row.

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
    limits : tuple of float
        (lower, upper) limits of ``q`` [rad or m].
    name : str
    servo : ServoCalibration or None
    max_velocity, max_acceleration : float
        Joint speed [rad/s or m/s] and acceleration limits; ``inf`` if unknown.
    """

    a: float = 0.0
    alpha: float = 0.0
    d: float = 0.0
    theta: float = 0.0
    joint_type: JointType = JointType.REVOLUTE
    limits: tuple = (-math.pi, math.pi)
    name: str = ""
    servo: ServoCalibration | None = None
    max_velocity: float = math.inf
    max_acceleration: float = math.inf

    @property
    def is_revolute(self):
        return self.joint_type is JointType.REVOLUTE
