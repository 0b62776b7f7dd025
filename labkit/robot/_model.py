"""The robot model: a frozen :class:`Robot` of Denavit-Hartenberg :class:`~labkit.robot.Link` rows.

A robot is data. Convenience methods (``robot.fk(q)``, ``robot.jacobian(q)``,
``robot.ik(target)``) delegate to the pure functions of :mod:`labkit.kinematics`,
imported lazily (kinematics depends only on :mod:`labkit.robot.types`, so this
closes no import cycle).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from labkit.validation import as_batch, as_number, readonly
from labkit.exceptions import JointLimitError, LabkitError, RobotError, RobotFileError, ShapeError
from labkit.robot.types import Bus, BusGripper, Convention, Gripper, Link, _ANGLE_UNITS, _LENGTH_UNITS, _unit_scale
from labkit.robot._files import load_fields
from labkit.robot._bus import check_bus

__all__ = ["Robot"]


def _rigid(owner, name, T):
    """``T`` as a read-only (4, 4) rigid transform, else a clear error."""
    try:
        arr = np.array(T, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"{owner}: expected {name} as a (4, 4) array of numbers, got {T!r}") from None
    if arr.shape != (4, 4):
        raise ShapeError(f"expected {name} with shape (4, 4), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ShapeError(f"{owner}: expected finite {name}, got a non-finite value")
    R = arr[:3, :3]
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > 1e-9 or np.linalg.det(R) < 0 or np.abs(arr[3] - [0, 0, 0, 1]).max() > 1e-12:
        raise RobotError(
            f"{owner}: field '{name}': expected a rigid transform (orthonormal rotation, det +1, "
            f"last row [0, 0, 0, 1]), got max |R R^T - I| = {err:.2g}, det {np.linalg.det(R):.3g}, "
            f"last row {arr[3].tolist()}", name,
        )
    return readonly(arr)


def _frozen(arr):
    """``arr`` itself, made read-only (a view cached on the robot)."""
    arr.setflags(write=False)
    return arr


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
    up : ndarray, shape (3,)
        Unit vector pointing up (against gravity) in world coordinates, the
        frame ``base`` maps into and :func:`~labkit.kinematics.fk` reports in
        (robot-file key ``up``; default ``(0, 0, 1)``). The seed 000 arm's
        frame 0 has z pointing down: its file says ``up = [0, 0, -1]``.
    title, source : str
        Human description and provenance.
    gripper : Gripper or BusGripper or None
    path : str
        File it was loaded from ("" if built in code).
    length_unit, angle_unit : str
        Units declared by the file (used for display at the edges only).
    bus : Bus or None
        The servo bus (robot-file ``[bus]`` table) whose servos drive every joint (each
        ``Link.bus``), or None for hobby servos behind an Arduino.

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
    gripper: Gripper | BusGripper | None = None
    path: str = ""
    length_unit: str = "m"
    angle_unit: str = "rad"
    up: np.ndarray = field(default_factory=lambda: readonly(np.array([0.0, 0.0, 1.0])))
    bus: Bus | None = None

    def __post_init__(self):
        self._validate(None)

    def _validate(self, changed):
        """Check and normalise the fields in ``changed`` (None: all) and every rule reading one (:meth:`replace`)."""
        def touched(*names):
            return changed is None or not changed.isdisjoint(names)

        if touched("name") and (not isinstance(self.name, str) or not self.name):
            raise RobotError(f"Robot: field 'name': expected a non-empty string, got {self.name!r}", "name")
        owner = f"Robot {self.name!r}"
        if touched("links"):
            try:
                links = tuple(self.links)
            except TypeError:
                raise RobotError(f"{owner}: field 'links': expected a sequence of Link, got {self.links!r}",
                                 "links") from None
            if not links:
                raise RobotError(f"{owner}: field 'links': expected at least one Link, got {self.links!r}", "links")
            for i, lk in enumerate(links, start=1):
                if not isinstance(lk, Link):
                    raise RobotError(f"{owner}: field 'links[{i}]': expected a Link, got {lk!r}", f"links[{i}]")
            object.__setattr__(self, "links", links)
            names = self.joint_names
            dup = sorted({nm for nm in names if names.count(nm) > 1})
            if dup:
                raise RobotError(f"{owner}: field 'joint.name': expected distinct joint names, got {dup[0]!r} twice",
                                 "joint.name")
        links = self.links
        if touched("convention"):
            valid = [c.value for c in Convention] + ["craig"]
            if self.convention == "craig":
                object.__setattr__(self, "convention", Convention.MODIFIED)
            elif self.convention not in valid:
                raise RobotError(f"{owner}: field 'convention': expected one of {valid}, got "
                                 f"{self.convention!r}", "convention")
            object.__setattr__(self, "convention", Convention(self.convention))
        for name in ("base", "tool"):
            if touched(name):
                object.__setattr__(self, name, _rigid(owner, name, getattr(self, name)))
        if touched("gripper") and self.gripper is not None and not isinstance(self.gripper, (Gripper, BusGripper)):
            raise RobotError(f"{owner}: field 'gripper': expected a Gripper, a BusGripper or None, got "
                             f"{self.gripper!r}", "gripper")
        if touched("links", "gripper"):
            channels = [lk.servo.channel for lk in links if lk.servo] + \
                [g.channel for g in [self.gripper] if isinstance(g, Gripper)]
            if len(set(channels)) != len(channels):
                raise RobotError(f"{owner}: field 'servo.channel': expected distinct servo channels, got "
                                 f"{channels}", "servo.channel")
        if touched("length_unit") and self.length_unit not in _LENGTH_UNITS:
            raise RobotError(f"{owner}: field 'units.length': expected one of {sorted(_LENGTH_UNITS)}, "
                             f"got {self.length_unit!r}", "units.length")
        if touched("angle_unit") and self.angle_unit not in _ANGLE_UNITS:
            raise RobotError(f"{owner}: field 'units.angle': expected one of {sorted(_ANGLE_UNITS)}, "
                             f"got {self.angle_unit!r}", "units.angle")
        if touched("links", "bus", "gripper"):
            check_bus(owner, self.bus, links, self.gripper)
        if touched("up"):
            up = as_batch(self.up, (), "up (a direction in world coordinates)", finite=False)
            if up.shape != (3,):
                raise ShapeError(f"expected up with shape (3,) (a direction in world coordinates), got {up.shape}")
            norm = float(np.linalg.norm(up))
            if not (np.isfinite(norm) and norm > 0.0):
                raise ShapeError(f"expected up to be a finite non-zero direction, got {up.tolist()}")
            object.__setattr__(self, "up", readonly(up / norm))

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

    @cached_property
    def is_revolute(self):
        """Boolean mask of revolute joints, shape (n,) (read-only)."""
        return _frozen(np.array([lk.is_revolute for lk in self.links]))

    @cached_property
    def flip(self):
        """Boolean mask of flipped joints (variable enters negated), shape (n,) (read-only)."""
        return _frozen(np.array([lk.flip for lk in self.links]))

    @cached_property
    def joint_limits(self):
        """Joint limits, shape (n, 2) [rad or m] (read-only)."""
        return _frozen(np.array([lk.limits for lk in self.links], dtype=float))

    @cached_property
    def reach(self):
        """A bound of the reach [m]: ``sum |a| + sum |d|``, each prismatic joint's largest finite ``|limit|`` and
        ``|tool translation|`` (the length numeric tolerances scale with)."""
        lim = self.joint_limits[~self.is_revolute]
        stroke = np.abs(lim[np.isfinite(lim).all(axis=1)]).max(axis=1, initial=0.0).sum()
        return float(np.abs(self.a).sum() + np.abs(self.d).sum() + stroke + np.linalg.norm(self.tool[:3, 3]))

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
        q = as_batch(q, (self.n,), "q", finite=False)
        tol = as_number(tol, "tol")
        lim = self.joint_limits
        return np.logical_and.reduce((q >= lim[:, 0] - tol) & (q <= lim[:, 1] + tol), axis=-1)

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
        q = as_batch(q, (self.n,), "q")
        tol = as_number(tol, "tol")
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
        """Inverse kinematics; see :func:`labkit.kinematics.ik`.

        Parameters
        ----------
        target : array_like
            Position [m], planar ``(x, y, phi)`` [m, m, rad] or pose (4, 4),
            depending on the robot (see :func:`labkit.kinematics.ik`).
        **kwargs
            Passed to :func:`labkit.kinematics.ik` (``branch``, ``q_near``, ``solver``).

        Returns
        -------
        q : ndarray, shape (..., n)
            Joint values [rad, m] inside the joint limits.

        Raises
        ------
        UnreachableError
            A target lies outside the workspace.
        """
        from labkit import kinematics

        return kinematics.ik(self, target, **kwargs)

    def replace(self, **changes):
        """Copy with some fields replaced (as ``dataclasses.replace``).

        Only the replaced fields, and the rules that read them, are checked
        again: the rest of the robot was checked when it was built.

        Parameters
        ----------
        **changes
            Field names and their new values (e.g. ``name="copy"``, ``tool=T``).

        Returns
        -------
        Robot

        Examples
        --------
        >>> arm = Robot.load("puma560")
        >>> arm.replace(name="copy").name, arm.replace(name="copy").n
        ('copy', 6)
        """
        if not changes.keys() <= _FIELDS:
            return replace(self, **changes)  # raises the TypeError that names the unknown field
        new = object.__new__(type(self))
        new.__dict__.update({name: getattr(self, name) for name in _FIELDS}, **changes)
        new._validate({name for name, value in changes.items() if value is not getattr(self, name)})
        return new

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
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not -self.n <= index < self.n:
            raise RobotError(f"expected a link index from 0 to {self.n - 1}, got {index!r}")
        links[index] = replace(links[index], **changes)
        return self.replace(links=tuple(links))

    def with_payload(self, mass, com=(0.0, 0.0, 0.0)):
        """Copy carrying a point mass rigidly at the tool (added to the last link's inertial).

        Parameters
        ----------
        mass : float
            Payload mass [kg], >= 0.
        com : array_like, shape (3,)
            Where the payload's centre of mass sits, in the tool frame [m].

        Returns
        -------
        Robot
            The last link's ``inertial`` is the lumped body (its own mass, centre of mass and
            inertia plus the point mass, by the parallel-axis theorem); calling it twice adds twice.

        Examples
        --------
        >>> arm = Robot.load("puma560").with_payload(2.0, [0, 0, 0.1])
        >>> arm.links[-1].inertial.mass
        2.09
        """
        from labkit.robot._inertia import LinkInertia, lump

        owner = f"Robot {self.name!r}: with_payload"
        if isinstance(mass, bool) or not isinstance(mass, (int, float, np.integer, np.floating)) \
                or not math.isfinite(mass) or mass < 0:
            raise RobotError(f"{owner}: expected a mass >= 0 kg, got {mass!r}", "mass")
        try:
            c = as_batch(com, (3,), "com", finite=False)
        except ShapeError:
            c = None
        if c is None or c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ShapeError(f"{owner}: expected com with shape (3,) (finite numbers in the tool frame, m), "
                             f"got {com!r}")
        at = np.eye(4)
        at[:3, 3] = c
        own = self.links[-1].inertial or LinkInertia(0.0)
        body = lump([(own, np.eye(4)), (LinkInertia(float(mass)), self.tool @ at)])
        return self.with_link(self.n - 1, inertial=body)

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
        if not isinstance(name_or_path, (str, os.PathLike)):
            raise RobotError(f"expected a Robot, a bundled robot name or a robot file path, got {name_or_path!r}")
        fields = load_fields(name_or_path)
        try:
            return cls(**fields)
        except RobotFileError:
            raise
        except LabkitError as exc:  # a check of the robot as a whole: still name the file
            from labkit.robot._files import _resolve

            raise RobotFileError(_resolve(name_or_path), getattr(exc, "field", None) or "<robot>", str(exc)) from None

    @classmethod
    def from_urdf(cls, path, *, base_link=None, tip_link=None, name=None, parallel_tol=1e-12):
        """Import the serial chain ``base_link`` -> ``tip_link`` of a URDF file as modified DH.

        See :mod:`labkit.robot.urdf` for the conversion; save the result with
        :meth:`to_toml` to use it as a robot file (``labkit robots`` lists it).

        Parameters
        ----------
        path : str or os.PathLike
            The ``.urdf`` file.
        base_link, tip_link : str, optional
            Ends of the chain; default the root link and the leaf below it with the
            most moving joints on the way (it must be unique).
        name : str, optional
            Robot name; default the URDF's robot name.
        parallel_tol : float
            Angle [rad] within which consecutive axes count as parallel (see
            :func:`labkit.robot.urdf.urdf_fields`).

        Returns
        -------
        Robot
            Forward kinematics equal to the URDF chain's (``base`` and ``tool``
            carry the fixed transforms at the two ends).

        Raises
        ------
        RobotError
            Unreadable file, links not on one chain, or a joint that is not
            revolute, continuous, prismatic or fixed (named in the message).
        """
        from labkit.robot.urdf import urdf_fields

        return cls(**urdf_fields(path, base_link=base_link, tip_link=tip_link, name=name,
                                 parallel_tol=parallel_tol))

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
        from labkit.robot._files import dump

        length_unit = self.length_unit if length_unit is None else length_unit
        angle_unit = self.angle_unit if angle_unit is None else angle_unit
        _unit_scale(_LENGTH_UNITS, length_unit, "length_unit")
        _unit_scale(_ANGLE_UNITS, angle_unit, "angle_unit")
        text = dump(self, length_unit, angle_unit)
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
            theta_i, lower, upper`` (``a_{i-1}``/``alpha_{i-1}`` for modified DH);
            ``attrs["units"]`` maps the columns to their units (the limits' only when
            every joint is of one type).
        """
        import pandas as pd

        scale = _unit_scale(_LENGTH_UNITS, self.length_unit if length_unit is None else length_unit, "length_unit")
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
        table = pd.DataFrame(rows).set_index(pd.RangeIndex(1, self.n + 1, name="i"))
        lengths, angles = length_unit or self.length_unit, "deg" if degrees else "rad"
        limits = {lk.is_revolute for lk in self.links}
        limit_unit = (angles if limits == {True} else lengths) if len(limits) == 1 else ""
        table.attrs["units"] = {table.columns[2]: lengths, table.columns[3]: angles, "d_i": lengths,
                                "theta_i": angles, "lower": limit_unit, "upper": limit_unit}
        return table


#: the dataclass fields of a Robot
_FIELDS = frozenset(f.name for f in fields(Robot))
