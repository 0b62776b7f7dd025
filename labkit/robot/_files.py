"""Parse and write robot files (TOML, format ``labkit-robot/1``).

See ``docs/robot-files.md`` for the format. Units declared in ``[units]``
are converted at load: the :class:`~labkit.robot.Robot` is always in metres and
radians.
"""

from __future__ import annotations

import math
import os
import tomllib
from pathlib import Path

import numpy as np

from labkit.robot.types import (
    _ANGLE_UNITS, _LENGTH_UNITS, _PROTOCOL_NAME, FORMAT, Bus, BusServo, Convention, Gripper, BusGripper, JointType, Link,
    LinkInertia, Motor, ServoCalibration,
)
from labkit.data import robots_dir
from labkit.exceptions import LabkitError, RobotError, RobotFileError

_TOP_KEYS = {"format", "name", "title", "source", "convention", "units", "up", "joint", "tool", "base", "gripper", "bus"}
_JOINT_KEYS = {"name", "type", "a", "alpha", "d", "theta", "limits", "servo", "max_velocity", "max_acceleration",
               "flip", "bus", "mass", "com", "inertia", "motor"}
_MOTOR_KEYS = {"inertia", "gear_ratio", "viscous", "coulomb"}
_SERVO_KEYS = {"channel", "zero", "direction", "range", "pulse_us", "feedback_adc", "stall_torque", "no_load_speed"}
_FRAME_KEYS = {"translation", "rpy"}
_BUS_KEYS = {"protocol", "baudrate", "resolution", "latency"}
_TORQUES = {"stall_torque": "a torque > 0 N m", "torque_constant": "a torque constant > 0 N m/A"}  # datasheet numbers
_BUS_SERVO_KEYS = {"id", "zero", "direction", *_TORQUES}
#: smallest servo range [rad for a revolute joint, m for a prismatic one]: 0.01 rad is 0.6 deg
_MIN_SERVO_SPAN = {True: 0.01, False: 1e-4}


def _num(path, field, value, *, default=None):
    if value is None:
        if default is None:
            raise RobotFileError(path, field, "missing; expected a number")
        return default
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise RobotFileError(path, field, f"expected a finite number, got {value!r}")
    return float(value)


#: smallest speed or acceleration limit a file may give (in its units): below it a limit is a typo (1e-320)
_MIN_LIMIT = 1e-6


def _positive(path, field, value, scale=1.0):
    """An optional positive limit (speed, acceleration) of at least ``_MIN_LIMIT``, times ``scale``; None when absent."""
    v = _num(path, field, value, default=math.inf)
    if not v >= _MIN_LIMIT:
        raise RobotFileError(path, field, f"expected a positive number >= {_MIN_LIMIT:g}, got {value!r}")
    return None if v == math.inf else v * scale


def _text(path, field, value, *, empty=True):
    """A string of printable characters (no NUL, newline or other control character)."""
    if not isinstance(value, str) or (not empty and not value):
        raise RobotFileError(path, field, f"expected a {'' if empty else 'non-empty '}string, got {value!r}")
    bad = [c for c in value if not c.isprintable()]
    if bad:
        raise RobotFileError(path, field, f"expected printable characters, got {value!r} (with {bad[0]!r})")
    return value


def _pair(path, field, value):
    if not isinstance(value, list) or len(value) != 2:
        raise RobotFileError(path, field, f"expected [lower, upper], got {value!r}")
    lo, hi = (_num(path, field, v) for v in value)
    if not lo < hi:
        raise RobotFileError(path, field, f"expected lower < upper, got {value!r}")
    return lo, hi


def _within(path, field, values, lo, hi, unit):
    """``values`` (a tuple of numbers) if each lies in ``lo..hi``, else a RobotFileError."""
    if any(not lo <= v <= hi for v in values):
        shown = values[0] if len(values) == 1 else list(values)
        raise RobotFileError(path, field, f"expected values within {lo}..{hi} {unit}, got {shown!r}")
    return values


def _check_keys(path, where, table, allowed):
    if not isinstance(table, dict):
        raise RobotFileError(path, where, f"expected a table, got {table!r}")
    extra = sorted(set(table) - allowed)
    if extra:
        raise RobotFileError(
            path, f"{where}.{extra[0]}" if where else extra[0],
            f"unknown key; expected one of: {', '.join(sorted(allowed))}",
        )


def _frame(path, field, table, L, A):
    T = np.eye(4)
    if table is None:
        return T
    _check_keys(path, field, table, _FRAME_KEYS)
    xyz = table.get("translation", [0, 0, 0])
    rpy = table.get("rpy", [0, 0, 0])
    for key, v in (("translation", xyz), ("rpy", rpy)):
        if not isinstance(v, list) or len(v) != 3:
            raise RobotFileError(path, f"{field}.{key}", f"expected a list of 3 numbers, got {v!r}")
    T[:3, 3] = [_num(path, f"{field}.translation", v) * L for v in xyz]
    from labkit.rotations import matrix_from_rpy  # only files with a rotated base/tool need it

    T[:3, :3] = matrix_from_rpy([_num(path, f"{field}.rpy", v) * A for v in rpy])
    return T


def _up(path, value):
    """The world's up direction: a list of 3 numbers, not all zero; returned as a unit vector."""
    if value is None:
        return np.array([0.0, 0.0, 1.0])
    if not isinstance(value, list) or len(value) != 3:
        raise RobotFileError(path, "up", f"expected a list of 3 numbers (a direction in world coordinates), got {value!r}")
    v = np.array([_num(path, "up", x) for x in value])
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise RobotFileError(path, "up", f"expected a non-zero direction, got {value!r}")
    return v / norm


def _int(path, field, value, lo, hi, unit=""):
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise RobotFileError(path, field, f"expected an integer {lo}..{hi}{' ' + unit if unit else ''}, got {value!r}")
    return value


def _bus(path, table):
    """The ``[bus]`` table: ``protocol``, ``baudrate`` [bit/s], ``resolution`` [ticks/turn] (default 4096), ``latency`` [ms]."""
    if table is None:
        return None
    _check_keys(path, "bus", table, _BUS_KEYS)
    protocol = table.get("protocol")
    if not isinstance(protocol, str) or not _PROTOCOL_NAME.fullmatch(protocol):
        raise RobotFileError(path, "bus.protocol", "expected a bus protocol name such as 'dynamixel' or 'feetech' "
                             f"(lower-case letters, digits, '_'), got {protocol!r}")
    baud = _int(path, "bus.baudrate", table.get("baudrate", 1_000_000), 9600, 4_500_000, "bit/s")
    res = _int(path, "bus.resolution", table.get("resolution", 4096), 16, 1_048_576, "ticks/turn")
    latency = table.get("latency")
    if latency is not None:
        latency = _num(path, "bus.latency", latency)
        if not 0 <= latency <= 1000:
            raise RobotFileError(path, "bus.latency", f"expected the adapter latency 0..1000 ms, got {latency:g}")
    return Bus(protocol, baud, res, latency)


def _bus_servo(path, where, table, bus):
    """A joint's ``bus = { id, zero, direction }`` (needs the ``[bus]`` table for the resolution)."""
    _check_keys(path, f"{where}.bus", table, _BUS_SERVO_KEYS)
    if bus is None:
        raise RobotFileError(path, f"{where}.bus", "expected a [bus] table (protocol, baudrate, resolution) in the file, "
                             "got a bus servo without one")
    sid = _int(path, f"{where}.bus.id", table.get("id"), 0, 252)
    zero = _num(path, f"{where}.bus.zero", table.get("zero", bus.resolution // 2))
    if not 0 <= zero <= bus.resolution - 1:
        raise RobotFileError(path, f"{where}.bus.zero", f"expected a position 0..{bus.resolution - 1} ticks, got {zero:g}")
    direction = table.get("direction", 1)
    if isinstance(direction, bool) or direction not in (1, -1):
        raise RobotFileError(path, f"{where}.bus.direction", f"expected 1 or -1, got {direction!r}")
    return BusServo(sid, zero, direction, bus.resolution, *(_stall(path, f"{where}.bus", table, key) for key in _TORQUES))


def _bus_gripper(path, table, bus, angle):
    """``[gripper]`` with ``bus = { id, zero, direction }``, ``open``, ``closed`` [file's angle unit], ``max_torque`` [N m]."""
    _check_keys(path, "gripper", table, {"bus", "open", "closed", "max_torque"})
    servo = _bus_servo(path, "gripper", table["bus"], bus)
    open_, closed = (_num(path, f"gripper.{key}", table.get(key)) * angle for key in ("open", "closed"))
    torque = None if "max_torque" not in table else _num(path, "gripper.max_torque", table["max_torque"])
    try:
        return BusGripper(servo, open_, closed, torque)
    except RobotError as exc:
        raise RobotFileError(path, f"gripper.{exc.field}", str(exc).split(": ", 2)[-1]) from None


def _stall(path, where, table, key="stall_torque"):
    """A servo table's optional ``stall_torque`` [N m] (or ``torque_constant`` [N m/A]), SI whatever the file's units."""
    if key not in table:
        return None
    if not (v := _num(path, f"{where}.{key}", table[key])) > 0:
        raise RobotFileError(path, f"{where}.{key}", f"expected {_TORQUES[key]}, got {v:g}")
    return v


def _numbers(path, field, value, k):
    if not isinstance(value, list) or len(value) != k:
        raise RobotFileError(path, field, f"expected a list of {k} numbers, got {value!r}")
    return [_num(path, field, v) for v in value]


def _inertial(path, where, j, L):
    """A joint's ``mass`` [kg], ``com`` [L] and ``inertia`` [kg L^2] as a LinkInertia in SI, or None."""
    if not any(key in j for key in ("mass", "com", "inertia")):
        return None
    if "mass" not in j:
        raise RobotFileError(path, f"{where}.mass", "missing; expected the link's mass [kg] with com or inertia")
    mass = _num(path, f"{where}.mass", j["mass"])
    if mass < 0:
        raise RobotFileError(path, f"{where}.mass", f"expected a mass >= 0 kg, got {mass:g}")
    com = [v * L for v in _numbers(path, f"{where}.com", j.get("com", [0, 0, 0]), 3)]
    inertia = [v * L * L for v in _numbers(path, f"{where}.inertia", j.get("inertia", [0] * 6), 6)]
    try:
        return LinkInertia(mass, tuple(com), tuple(inertia))
    except RobotFileError:
        raise
    except LabkitError as exc:
        raise RobotFileError(path, f"{where}.inertia", str(exc).split(": ", 2)[-1]) from None


def _motor(path, where, table):
    """A joint's ``motor = { inertia, gear_ratio, viscous, coulomb = [plus, minus] }`` (SI, at the motor)."""
    if table is None:
        return None
    _check_keys(path, f"{where}.motor", table, _MOTOR_KEYS)
    values = dict(
        inertia=_num(path, f"{where}.motor.inertia", table.get("inertia", 0.0)),
        gear_ratio=_num(path, f"{where}.motor.gear_ratio", table.get("gear_ratio", 1.0)),
        viscous=_num(path, f"{where}.motor.viscous", table.get("viscous", 0.0)),
        coulomb=tuple(_numbers(path, f"{where}.motor.coulomb", table.get("coulomb", [0, 0]), 2)),
    )
    try:
        return Motor(**values)
    except LabkitError as exc:
        raise RobotFileError(path, f"{where}.motor.{getattr(exc, 'field', '')}", str(exc).split(": ", 2)[-1]) from None


def parse(data, path):
    """Check parsed TOML ``data`` (read from ``path``) and return the robot's fields.

    Parameters
    ----------
    data : dict
        The file's TOML tables (``tomllib.loads``).
    path : str or os.PathLike
        Where the data came from (named in error messages).

    Returns
    -------
    dict
        Keyword arguments of :class:`labkit.robot.Robot`, in SI units and radians.

    Raises
    ------
    RobotFileError
        Naming the file, the field and what was expected.
    """
    _check_keys(path, "", data, _TOP_KEYS)
    fmt = data.get("format", FORMAT)
    if fmt != FORMAT:
        raise RobotFileError(path, "format", f"expected {FORMAT!r}, got {fmt!r}")
    units = data.get("units", {})
    _check_keys(path, "units", units, {"length", "angle"})
    lu, au = units.get("length", "m"), units.get("angle", "rad")
    if not isinstance(lu, str) or lu not in _LENGTH_UNITS:
        raise RobotFileError(path, "units.length", f"expected one of {sorted(_LENGTH_UNITS)}, got {lu!r}")
    if not isinstance(au, str) or au not in _ANGLE_UNITS:
        raise RobotFileError(path, "units.angle", f"expected one of {sorted(_ANGLE_UNITS)}, got {au!r}")
    L, A = _LENGTH_UNITS[lu], _ANGLE_UNITS[au]
    for key in ("title", "source"):
        if not isinstance(data.get(key, ""), str):
            raise RobotFileError(path, key, f"expected a string, got {data[key]!r}")
    conv = data.get("convention")
    valid = [c.value for c in Convention] + ["craig"]
    if not isinstance(conv, str) or conv not in valid:
        raise RobotFileError(path, "convention", f"expected one of {valid}, got {conv!r}")
    conv = Convention.MODIFIED if conv == "craig" else Convention(conv)
    joints = data.get("joint")
    if not isinstance(joints, list) or not joints:
        raise RobotFileError(path, "joint", "expected at least one [[joint]] table")
    bus = _bus(path, data.get("bus"))
    links = []
    for i, j in enumerate(joints, start=1):
        where = f"joint[{i}]"
        _check_keys(path, where, j, _JOINT_KEYS)
        _text(path, f"{where}.name", j.get("name", ""))
        jt = j.get("type", "revolute")
        if not isinstance(jt, str) or jt not in ("revolute", "prismatic"):
            raise RobotFileError(path, f"{where}.type", f"expected 'revolute' or 'prismatic', got {jt!r}")
        jt = JointType(jt)
        rev = jt is JointType.REVOLUTE
        qscale = A if rev else L
        lim = j.get("limits")
        if lim is None:
            limits = (-math.pi, math.pi) if rev else None
            if limits is None:
                raise RobotFileError(path, f"{where}.limits", "required for a prismatic joint; expected [lower, upper]")
        else:
            lo, hi = _pair(path, f"{where}.limits", lim)
            limits = (lo * qscale, hi * qscale)
        servo = None
        if "servo" in j:
            s = j["servo"]
            _check_keys(path, f"{where}.servo", s, _SERVO_KEYS)
            ch = s.get("channel")
            if isinstance(ch, bool) or not isinstance(ch, int) or not 0 <= ch <= 5:
                raise RobotFileError(path, f"{where}.servo.channel", f"expected an integer 0-5, got {ch!r}")
            direction = s.get("direction", 1)
            if isinstance(direction, bool) or not isinstance(direction, int) or direction not in (1, -1):
                raise RobotFileError(path, f"{where}.servo.direction", f"expected 1 or -1, got {direction!r}")
            # a hobby servo's 180 deg; an RC linear servo's stroke: by default the joint's limits
            default = [0, 180 if au == "deg" else math.pi] if rev else [v / qscale for v in limits]
            ar = _pair(path, f"{where}.servo.range", s.get("range", default))
            if (ar[1] - ar[0]) * qscale < _MIN_SERVO_SPAN[rev]:
                raise RobotFileError(path, f"{where}.servo.range", f"expected a range of at least "
                                     f"{_MIN_SERVO_SPAN[rev] / qscale:g} {au if rev else lu}, got {s.get('range')!r}")
            pr = _pair(path, f"{where}.servo.pulse_us", s.get("pulse_us", [500, 2500]))
            _within(path, f"{where}.servo.pulse_us", pr, 400, 2600, "us (RC servo pulses)")
            adc = _pair(path, f"{where}.servo.feedback_adc", s.get("feedback_adc", [102.3, 920.7]))
            servo = ServoCalibration(
                channel=ch, zero=_num(path, f"{where}.servo.zero", s.get("zero", 0.0)) * qscale, direction=direction,
                angle_range=(ar[0] * qscale, ar[1] * qscale), pulse_range=pr,
                feedback_adc=_within(path, f"{where}.servo.feedback_adc", adc, 0, 1023, "ADC counts"),
                stall_torque=_stall(path, f"{where}.servo", s),
                no_load_speed=_positive(path, f"{where}.servo.no_load_speed", s.get("no_load_speed"), qscale))
        bus_servo = _bus_servo(path, where, j["bus"], bus) if "bus" in j else None
        if bus_servo is not None and servo is not None:
            raise RobotFileError(path, f"{where}.bus", "expected either a hobby servo (servo = {...}) or a bus servo "
                                 "(bus = {...}), got both")
        if bus_servo is not None and not rev:
            raise RobotFileError(path, f"{where}.bus", "expected a revolute joint on a servo bus, got a prismatic one")
        if bus is not None and bus_servo is None:
            raise RobotFileError(path, f"{where}.bus", "expected bus = { id = ..., zero = ..., direction = ... } on "
                                 "every joint of a robot with a [bus] table, got none")
        flip = j.get("flip", False)
        if not isinstance(flip, bool):
            raise RobotFileError(path, f"{where}.flip", f"expected true or false, got {flip!r}")
        links.append(
            Link(
                a=_num(path, f"{where}.a", j.get("a", 0.0)) * L,
                alpha=_num(path, f"{where}.alpha", j.get("alpha", 0.0)) * A,
                d=_num(path, f"{where}.d", j.get("d", 0.0)) * L,
                theta=_num(path, f"{where}.theta", j.get("theta", 0.0)) * A,
                joint_type=jt,
                limits=limits,
                name=str(j.get("name", f"q{i}")),
                servo=servo,
                max_velocity=_positive(path, f"{where}.max_velocity", j.get("max_velocity"), qscale),
                max_acceleration=_positive(path, f"{where}.max_acceleration", j.get("max_acceleration"), qscale),
                flip=flip,
                bus=bus_servo,
                inertial=_inertial(path, where, j, L),
                motor=_motor(path, where, j.get("motor")),
            )
        )
    names = [lk.name for lk in links]
    dup = sorted({nm for nm in names if names.count(nm) > 1})
    if dup:
        raise RobotFileError(path, "joint.name", f"expected distinct joint names, got {dup[0]!r} twice")
    channels = [lk.servo.channel for lk in links if lk.servo]
    gripper = None
    if isinstance(data.get("gripper"), dict) and "bus" in data["gripper"]:
        gripper = _bus_gripper(path, data["gripper"], bus, A)
    elif "gripper" in data:
        g = data["gripper"]
        _check_keys(path, "gripper", g, {"channel", "open_us", "closed_us"})
        ch = g.get("channel")
        if isinstance(ch, bool) or not isinstance(ch, int) or not 0 <= ch <= 5:
            raise RobotFileError(path, "gripper.channel", f"expected an integer 0-5, got {ch!r}")
        open_us, closed_us = (_within(path, f"gripper.{key}", (_num(path, f"gripper.{key}", g.get(key)),), 400, 2600,
                                      "us (RC servo pulses)")[0] for key in ("open_us", "closed_us"))
        if open_us == closed_us:
            raise RobotFileError(path, "gripper.closed_us", f"expected a pulse other than open_us = {open_us:g} us "
                                 f"(the gripper would never move), got {closed_us:g}")
        gripper = Gripper(ch, open_us, closed_us)
        channels.append(ch)
    if len(set(channels)) != len(channels):
        raise RobotFileError(path, "servo.channel", f"expected distinct servo channels, got {channels}")
    name = _text(path, "name", data.get("name"), empty=False)
    return dict(
        name=name,
        links=tuple(links),
        convention=conv,
        base=_frame(path, "base", data.get("base"), L, A),
        tool=_frame(path, "tool", data.get("tool"), L, A),
        up=_up(path, data.get("up")),
        title=str(data.get("title", "")),
        source=str(data.get("source", "")),
        gripper=gripper,
        path=str(path),
        length_unit=lu,
        angle_unit=au,
        bus=bus,
    )


def _toml_str(text):
    """A TOML basic string (JSON string syntax is valid TOML)."""
    import json  # only when writing a file

    return json.dumps(str(text), ensure_ascii=False)


def _fmt(x):
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return f"{int(x)}"
    return repr(round(x, 12))


def _sig(x):
    """A number to 15 significant digits (inertias of small links are below _fmt's 1e-12 grid)."""
    x = float(f"{float(x):.15g}")
    return _fmt(x) if x == int(x) else repr(x)


def dump(robot, length_unit="m", angle_unit="rad"):
    """TOML text of ``robot`` in the given display units (round-trips through :func:`parse`).

    Parameters
    ----------
    robot : Robot
        The robot to write.
    length_unit : {"m", "mm", "cm"}
        Unit of the lengths in the text.
    angle_unit : {"rad", "deg"}
        Unit of the angles in the text.

    Returns
    -------
    str
        The robot file (format ``labkit-robot/1``).
    """
    L, A = _LENGTH_UNITS[length_unit], _ANGLE_UNITS[angle_unit]
    out = [
        f'format = "{FORMAT}"',
        f"name = {_toml_str(robot.name)}",
        f"title = {_toml_str(robot.title)}",
        f"source = {_toml_str(robot.source)}",
        f'convention = "{robot.convention.value}"',
        f'units = {{ length = "{length_unit}", angle = "{angle_unit}" }}',
    ]
    if not np.array_equal(robot.up, [0.0, 0.0, 1.0]):
        out.append("up = [" + ", ".join(_fmt(v) for v in robot.up) + "]  # world up, in world coordinates")
    out.append("")
    for lk in robot.links:
        rev = lk.is_revolute
        qs = A if rev else L
        out += [
            "[[joint]]",
            f"name = {_toml_str(lk.name)}",
            f'type = "{lk.joint_type.value}"',
            f"a = {_fmt(lk.a / L)}",
            f"alpha = {_fmt(lk.alpha / A)}",
            f"d = {_fmt(lk.d / L)}",
            f"theta = {_fmt(lk.theta / A)}",
            f"limits = [{_fmt(lk.limits[0] / qs)}, {_fmt(lk.limits[1] / qs)}]",
        ]
        if lk.flip:
            out.append("flip = true")
        if lk.max_velocity is not None:
            out.append(f"max_velocity = {_fmt(lk.max_velocity / qs)}")
        if lk.max_acceleration is not None:
            out.append(f"max_acceleration = {_fmt(lk.max_acceleration / qs)}")
        if lk.servo:
            s = lk.servo
            out.append(
                f"servo = {{ channel = {s.channel}, zero = {_fmt(s.zero / qs)}, direction = {s.direction}, "
                f"range = [{_fmt(s.angle_range[0] / qs)}, {_fmt(s.angle_range[1] / qs)}], "
                f"pulse_us = [{_fmt(s.pulse_range[0])}, {_fmt(s.pulse_range[1])}], "
                f"feedback_adc = [{_fmt(s.feedback_adc[0])}, {_fmt(s.feedback_adc[1])}]"
                + (f", stall_torque = {_sig(s.stall_torque)}" if s.stall_torque is not None else "")
                + (f", no_load_speed = {_fmt(s.no_load_speed / qs)}" if s.no_load_speed is not None else "") + " }"
            )
        if lk.bus:
            stall = f", stall_torque = {_sig(lk.bus.stall_torque)}" if lk.bus.stall_torque is not None else ""
            stall += f", torque_constant = {_sig(lk.bus.torque_constant)}" if lk.bus.torque_constant is not None else ""
            out.append(f"bus = {{ id = {lk.bus.id}, zero = {_fmt(lk.bus.zero)}, direction = {lk.bus.direction}{stall} }}")
        if lk.inertial:
            out += [f"mass = {_sig(lk.inertial.mass)}",
                    "com = [" + ", ".join(_sig(v / L) for v in lk.inertial.com) + "]",
                    "inertia = [" + ", ".join(_sig(v / (L * L)) for v in lk.inertial.inertia) + "]"]
        if lk.motor:
            m = lk.motor
            out.append(f"motor = {{ inertia = {_sig(m.inertia)}, gear_ratio = {_sig(m.gear_ratio)}, "
                       f"viscous = {_sig(m.viscous)}, coulomb = [{_sig(m.coulomb[0])}, {_sig(m.coulomb[1])}] }}")
        out.append("")
    if robot.bus:
        out += ["[bus]", f'protocol = "{robot.bus.protocol}"', f"baudrate = {robot.bus.baudrate}",
                f"resolution = {robot.bus.resolution}", ""]
    for name in ("base", "tool"):
        T = getattr(robot, name)
        if not np.allclose(T, np.eye(4), atol=0, rtol=0):
            from labkit.rotations import rpy_from_matrix

            rpy = rpy_from_matrix(T[:3, :3])
            out += [
                f"[{name}]",
                "translation = [" + ", ".join(_fmt(v / L) for v in T[:3, 3]) + "]",
                "rpy = [" + ", ".join(_fmt(v / A) for v in rpy) + "]",
                "",
            ]
    if isinstance(robot.gripper, BusGripper):
        g = robot.gripper
        torque = "" if g.max_torque is None else f"max_torque = {_fmt(g.max_torque)}\n"
        out += ["[gripper]", f"bus = {{ id = {g.servo.id}, zero = {_fmt(g.servo.zero)}, direction = {g.servo.direction} }}",
                f"open = {_fmt(g.open / A)}", f"closed = {_fmt(g.closed / A)}", torque]
    elif robot.gripper:
        g = robot.gripper
        out += [
            "[gripper]",
            f"channel = {g.channel}",
            f"open_us = {_fmt(g.open_us)}",
            f"closed_us = {_fmt(g.closed_us)}",
            "",
        ]
    return "\n".join(out)


# -- locating robot files ----------------------------------------------------

def robot_search_path():
    """Directories searched for bundled robot names, in order.

    ``$LABKIT_ROBOT_PATH`` (os.pathsep-separated) first, then the robots
    shipped with labkit.

    Returns
    -------
    list of pathlib.Path
    """
    dirs = [Path(p) for p in os.environ.get("LABKIT_ROBOT_PATH", "").split(os.pathsep) if p]
    return dirs + [robots_dir()]


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
            raise RobotFileError(p, "<file>", "expected a robot file, got a folder" if p.is_dir() else "no such robot file")
        return p
    robots = bundled_robots()
    if str(name_or_path) in robots:
        return robots[str(name_or_path)]
    raise RobotFileError(
        name_or_path,
        "<name>",
        f"unknown robot; expected a file path or one of: {', '.join(robots) or '(none found)'}",
    )


def _read_text(path):
    """The text of robot file ``path``: UTF-8, a leading byte-order mark (as Notepad writes) dropped; else a
    :class:`RobotFileError` (unreadable; not UTF-8, naming the first bad byte and its line)."""
    try:
        text = (raw := Path(path).read_bytes()).decode("utf-8-sig")
    except OSError as exc:
        raise RobotFileError(path, "<file>", f"cannot read the file: {exc}") from None
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise RobotFileError(path, "<file>", f"expected UTF-8 text, got byte 0x{raw[exc.start]:02x} on line {line}; "
                             "save the file as UTF-8") from None
    return text


def load_fields(name_or_path):
    """Find, read and parse a robot file; return the :class:`labkit.robot.Robot` fields.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A bundled robot name or a path to a ``.toml`` robot file.

    Returns
    -------
    dict
        Keyword arguments of :class:`labkit.robot.Robot`.

    Raises
    ------
    RobotFileError
        The file is missing, unreadable, not TOML, or malformed.
    """
    path = _resolve(name_or_path)
    text = _read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotFileError(path, "<toml>", f"not valid TOML: {exc}") from None
    return parse(data, path)
