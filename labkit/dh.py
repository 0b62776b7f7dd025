"""Robot description: Denavit-Hartenberg links, servo calibration, robot files.

A robot is data: a frozen :class:`Robot` of :class:`Link` rows loaded from a
small TOML file (format documented in ``docs/robot-files.md``). Lengths are
stored in metres and angles in radians whatever units the file declares.
Convenience methods (``robot.fk(q)``) delegate to the pure functions of
:mod:`labkit.kinematics` and :mod:`labkit.ik`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path

import numpy as np
import tomllib

from labkit._validation import readonly
from labkit.exceptions import JointLimitError, RobotFileError

__all__ = [
    "Convention",
    "JointType",
    "ServoCalibration",
    "Gripper",
    "Link",
    "Robot",
    "bundled_robots",
    "robot_search_path",
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


@dataclass(frozen=True, eq=False)
class Robot:
    """A serial arm described by Denavit-Hartenberg rows.

    Attributes
    ----------
    name : str
        Short name (the robot file's stem for bundled robots).
    links : tuple of Link
    convention : Convention
    base : ndarray, shape (4, 4)
        ``world_from_frame0`` transform [m].
    tool : ndarray, shape (4, 4)
        ``frame_n_from_tool`` transform [m].
    title, source : str
        Human description and provenance.
    gripper : Gripper or None
    path : str
        File it was loaded from ("" if built in code).
    length_unit, angle_unit : str
        Units declared by the file (used for display at the edges only).

    Examples
    --------
    >>> arm = Robot.load("planar3r_seed004")
    >>> arm.n
    3
    >>> np.round(arm.fk([0.0, 0.0, 0.0])[:3, 3], 3)
    array([0.47, 0.  , 0.  ])
    """

    name: str
    links: tuple
    convention: Convention = Convention.STANDARD
    base: np.ndarray = field(default_factory=lambda: readonly(np.eye(4)))
    tool: np.ndarray = field(default_factory=lambda: readonly(np.eye(4)))
    title: str = ""
    source: str = ""
    gripper: Gripper | None = None
    path: str = ""
    length_unit: str = "m"
    angle_unit: str = "rad"

    def __post_init__(self):
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "convention", Convention(self.convention))
        object.__setattr__(self, "base", readonly(self.base))
        object.__setattr__(self, "tool", readonly(self.tool))
        for name in ("base", "tool"):
            T = getattr(self, name)
            if T.shape != (4, 4):
                raise ValueError(f"expected {name} with shape (4, 4), got {T.shape}")

    # -- vectorised views of the DH table ---------------------------------
    @property
    def n(self):
        """Number of joints."""
        return len(self.links)

    @property
    def a(self):
        """Link lengths, shape (n,) [m]."""
        return np.array([lk.a for lk in self.links])

    @property
    def alpha(self):
        """Link twists, shape (n,) [rad]."""
        return np.array([lk.alpha for lk in self.links])

    @property
    def d(self):
        """Link offsets, shape (n,) [m]."""
        return np.array([lk.d for lk in self.links])

    @property
    def theta(self):
        """Joint angle offsets, shape (n,) [rad]."""
        return np.array([lk.theta for lk in self.links])

    @property
    def is_revolute(self):
        """Boolean mask of revolute joints, shape (n,)."""
        return np.array([lk.is_revolute for lk in self.links])

    @property
    def joint_limits(self):
        """Joint limits, shape (n, 2) [rad or m]."""
        return np.array([lk.limits for lk in self.links], dtype=float)

    @property
    def joint_names(self):
        """Joint names, tuple of str."""
        return tuple(lk.name or f"q{i + 1}" for i, lk in enumerate(self.links))

    def within_limits(self, q, tol=1e-9):
        """Whether each configuration lies inside the joint limits.

        Parameters
        ----------
        q : array_like, shape (..., n)
            Joint values [rad, m].
        tol : float
            Slack allowed beyond each limit [rad, m].

        Returns
        -------
        ok : ndarray of bool, shape (...)
        """
        q = np.asarray(q, dtype=float)
        lim = self.joint_limits
        return np.all((q >= lim[:, 0] - tol) & (q <= lim[:, 1] + tol), axis=-1)

    def check_limits(self, q, tol=1e-9):
        """Raise :class:`JointLimitError` naming the first joint outside its limits.

        Parameters
        ----------
        q : array_like, shape (..., n)
            Joint values [rad, m].
        tol : float
            Slack allowed beyond each limit [rad, m].

        Raises
        ------
        JointLimitError
            With ``joint`` (0-based) and ``index`` (batch index) of the first
            violation; the message gives the value and limits in deg or m.
        """
        q = np.asarray(q, dtype=float)
        lim = self.joint_limits
        bad = (q < lim[:, 0] - tol) | (q > lim[:, 1] + tol)
        if np.any(bad):
            idx = np.argwhere(bad)[0]
            j = int(idx[-1])
            val = q[tuple(idx)]
            unit = "deg" if self.links[j].is_revolute else "m"
            conv = math.degrees if self.links[j].is_revolute else float
            raise JointLimitError(
                f"{self.name}: joint {j + 1} ({self.joint_names[j]}) = {conv(val):.4g} {unit} "
                f"outside its limits [{conv(lim[j, 0]):.4g}, {conv(lim[j, 1]):.4g}] {unit}",
                joint=j,
                index=tuple(int(i) for i in idx[:-1]),
            )

    # -- delegates ----------------------------------------------------------
    def fk(self, q, *, frames=False):
        """Forward kinematics; see :func:`labkit.kinematics.fk`.

        Parameters
        ----------
        q : array_like, shape (..., n)
            Joint values [rad, m].
        frames : bool
            Return every link frame (:func:`labkit.kinematics.fk_frames`) instead of
            the tool pose only.

        Returns
        -------
        ndarray, shape (..., 4, 4) or (..., n + 2, 4, 4)
            Base-from-tool transform [m], or the frames as
            :func:`labkit.kinematics.fk_frames` returns them.
        """
        from labkit import kinematics

        if frames:
            return kinematics.fk_frames(self, q)
        return kinematics.fk(self, q)

    def jacobian(self, q, **kwargs):
        """Geometric Jacobian; see :func:`labkit.kinematics.jacobian`.

        Parameters
        ----------
        q : array_like, shape (..., n)
            Joint values [rad, m].
        **kwargs
            Passed to :func:`labkit.kinematics.jacobian` (e.g. ``point``, ``frame``).

        Returns
        -------
        ndarray, shape (..., 6, n)
            Rows ``vx, vy, vz, wx, wy, wz``; columns per joint [m/rad or 1].
        """
        from labkit import kinematics

        return kinematics.jacobian(self, q, **kwargs)

    def ik(self, target, **kwargs):
        """Inverse kinematics; see :func:`labkit.ik.ik`.

        Parameters
        ----------
        target : array_like
            Position [m], planar ``(x, y, phi)`` [m, m, rad] or pose (4, 4),
            depending on the robot (see :func:`labkit.ik.ik`).
        **kwargs
            Passed to :func:`labkit.ik.ik` (``branch``, ``q_near``, ``solver``).

        Returns
        -------
        q : ndarray, shape (..., n)
            Joint values [rad, m] inside the joint limits.

        Raises
        ------
        UnreachableError
            A target lies outside the workspace.
        """
        from labkit import ik

        return ik.ik(self, target, **kwargs)

    def replace(self, **changes):
        """Copy with some fields replaced (``dataclasses.replace``).

        Parameters
        ----------
        **changes
            Field names and their new values (e.g. ``name="copy"``, ``tool=T``).

        Returns
        -------
        Robot
        """
        return replace(self, **changes)

    def with_link(self, index, **changes):
        """Copy with fields of one link replaced.

        Parameters
        ----------
        index : int
            0-based link index.
        **changes
            :class:`Link` field names and their new values (SI units, e.g. ``a=0.1``).

        Returns
        -------
        Robot
        """
        links = list(self.links)
        links[index] = replace(links[index], **changes)
        return replace(self, links=tuple(links))

    # -- files --------------------------------------------------------------
    @classmethod
    def load(cls, name_or_path):
        """Load a robot by bundled name (see ``labkit robots``) or file path.

        Parameters
        ----------
        name_or_path : str or os.PathLike
            A bundled robot name such as ``"arduino_arm_3dof"`` or a path to a
            ``.toml`` robot file.

        Returns
        -------
        Robot

        Raises
        ------
        RobotFileError
            If the file is missing or malformed; the message names the file,
            the field and what was expected.
        """
        if isinstance(name_or_path, Robot):
            return name_or_path
        path = _resolve(name_or_path)
        return _load_file(path)

    def to_toml(self, path=None, *, length_unit=None, angle_unit=None):
        """Write the robot as a robot file (returns the TOML text).

        Parameters
        ----------
        path : str or os.PathLike, optional
            Where to write; nothing is written if omitted.
        length_unit, angle_unit : str, optional
            Units to declare ("m"/"mm"/"cm", "rad"/"deg"); default: the units
            the robot was loaded with.

        Returns
        -------
        str
            The robot file text.
        """
        from labkit._robotfile import dump

        text = dump(self, length_unit or self.length_unit, angle_unit or self.angle_unit)
        if path is not None:
            Path(path).write_text(text)
        return text

    def __repr__(self):
        return f"Robot(name={self.name!r}, n={self.n}, convention={self.convention.value!r})"

    def dh_table(self, *, degrees=True, length_unit=None):
        """The DH table as a pandas DataFrame (degrees and file units for display).

        Parameters
        ----------
        degrees : bool
            Angles (``alpha``, ``theta`` and revolute limits) in degrees, else rad.
        length_unit : str, optional
            Unit of lengths and prismatic limits ("m"/"mm"/"cm"); default: the
            unit the robot was loaded with.

        Returns
        -------
        pandas.DataFrame
            One row per joint, indexed ``i = 1..n``: ``joint, type, a, alpha, d_i,
            theta_i, lower, upper`` (``a_{i-1}``/``alpha_{i-1}`` for modified DH).
        """
        import pandas as pd

        scale = _LENGTH_UNITS[length_unit or self.length_unit]
        ang = math.degrees if degrees else float
        mod = self.convention is Convention.MODIFIED
        rows = []
        for i, lk in enumerate(self.links):
            rows.append(
                {
                    "joint": self.joint_names[i],
                    "type": lk.joint_type.value,
                    ("a_{i-1}" if mod else "a_i"): lk.a / scale,
                    ("alpha_{i-1}" if mod else "alpha_i"): ang(lk.alpha),
                    "d_i": lk.d / scale,
                    "theta_i": ang(lk.theta),
                    "lower": ang(lk.limits[0]) if lk.is_revolute else lk.limits[0] / scale,
                    "upper": ang(lk.limits[1]) if lk.is_revolute else lk.limits[1] / scale,
                }
            )
        return pd.DataFrame(rows).set_index(pd.RangeIndex(1, self.n + 1, name="i"))


# -- locating and parsing robot files -----------------------------------------

def robot_search_path():
    """Directories searched for bundled robot names, in order.

    ``$LABKIT_ROBOT_PATH`` (os.pathsep-separated) first, then the robots
    shipped with labkit.

    Returns
    -------
    list of pathlib.Path
    """
    dirs = [Path(p) for p in os.environ.get("LABKIT_ROBOT_PATH", "").split(os.pathsep) if p]
    here = Path(__file__).resolve().parent
    for cand in (here.parent / "data" / "robots", here / "robots"):
        if cand.is_dir():
            dirs.append(cand)
    return dirs


def bundled_robots():
    """Names and paths of the robots found on :func:`robot_search_path`.

    Returns
    -------
    dict
        ``{name: Path}`` sorted by name.
    """
    found = {}
    for d in robot_search_path():
        for p in sorted(d.glob("*.toml")):
            found.setdefault(p.stem, p)
    return dict(sorted(found.items()))


def _resolve(name_or_path):
    p = Path(os.fspath(name_or_path))
    if p.suffix == ".toml" or p.is_file() or os.sep in str(name_or_path):
        if not p.is_file():
            raise RobotFileError(p, "<file>", "no such robot file")
        return p
    robots = bundled_robots()
    if str(name_or_path) in robots:
        return robots[str(name_or_path)]
    raise RobotFileError(
        name_or_path,
        "<name>",
        f"unknown robot; expected a file path or one of: {', '.join(robots) or '(none found)'}",
    )


def _load_file(path):
    from labkit._robotfile import parse

    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotFileError(path, "<file>", f"cannot read the file: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotFileError(path, "<toml>", f"not valid TOML: {exc}") from None
    return parse(data, path)
