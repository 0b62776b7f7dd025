"""Guided calibration of a servo-bus arm: each joint's zero, direction and range, moved by hand.

With torque off on every servo, the student moves each joint in turn: to its zero mark, a little
towards + (the labelled move that gives the servo's direction), then slowly from stop to stop.
labkit reads the present positions all along (a sync read every few milliseconds from a thread
while the prompt waits) and turns them into the robot file's ``bus = { id, zero, direction }`` and
the joint's ``limits``:

- the readings are *unwrapped*: the encoder reads one turn, ``0 .. resolution - 1``, and a joint
  turning through its seam jumps from 4095 to 0; successive readings differ by far less than half a
  turn, so each jump is a wrap (:func:`unwrap_ticks`);
- the direction is the sign of the labelled move; a move under ``min_move`` is refused;
- the range swept is compared with the file's limits: a joint that stops short of them (a wrist
  roll with a stop at 340 deg where the file says more) gets its limits ``margin`` inside the
  stops it met; one that turns a full turn keeps the file's limits;
- if the limits, mapped to the servo's ticks from the zero, cross the seam, the servo cannot go
  there in position mode: labkit writes the servo's homing offset (Dynamixel address 20, Feetech
  ``Ofs``; EEPROM, torque off, Feetech's lock opened and closed) so that the middle of the range
  reads half a turn, keeping the offset within what the servo takes (Feetech: 11 bits and a sign,
  |offset| <= 2047, the "magnitude exceeds 2047" of LeRobot's homing), and checks that the servo
  reports the shift; with ``rehome=False`` it says what to do instead.

:func:`calibrate_servos` runs the steps on an open bus (a device or a :class:`BusEmulator`'s
pseudo-terminal) and returns a :class:`BusCalibration`; ``ask(step)`` is called at each step and
returns when the student is done (``input`` on a terminal, :meth:`VirtualHand.answer` on a virtual
bus, anything a test or a notebook scripts). Writing the robot file is
:func:`labkit.robot.edit_bus_calibration`; ``labkit calibrate-bus`` and
:func:`labkit.arm.calibrate_bus` do both.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, replace

import numpy as np

from labkit.exceptions import BusCalibrationError, BusFault, OptionError
from labkit.robot import Robot
from labkit.arm.bus._registry import bus_module

__all__ = ["CalibrationStep", "JointBusCalibration", "BusCalibration", "unwrap_ticks", "solve_joint",
           "calibrate_servos"]

#: the kinds of step, in the order each joint goes through them
STEP_KINDS = ("zero", "plus", "range")
#: a sweep wider than this fraction of a turn means the joint turns fully (no stop met)
FULL_TURN = 355.0 / 360.0


@dataclass(frozen=True)
class CalibrationStep:
    """One thing the student is asked to do.

    Attributes
    ----------
    index : int
        The joint (0-based).
    joint : str
        Its name.
    move : {"zero", "plus", "range"}
        Move it to its zero mark; move it a little towards +; move it from stop to stop.
    text : str
        The prompt.
    """

    index: int
    joint: str
    move: str
    text: str

    def __post_init__(self):
        if self.move not in STEP_KINDS:
            raise OptionError(f"expected a calibration step's move, one of {', '.join(STEP_KINDS)}, got {self.move!r}")


@dataclass(frozen=True)
class JointBusCalibration:
    """What the calibration found for one joint, and what the robot file said before.

    Attributes
    ----------
    name : str
    id : int
        Servo id.
    zero, direction : int
        The new ``bus`` zero [ticks] and direction.
    limits : tuple of float
        The new joint limits [rad].
    zero_before, direction_before : float, int
        The robot file's.
    limits_before : tuple of float
        The robot file's [rad].
    swept : tuple of float or None
        The range the hand moved the joint through [rad], ``None`` when it turned fully.
    offset_before : int
        The servo's homing offset before [ticks].
    offset : int or None
        The homing offset written [ticks], ``None`` when none was needed.
    notes : tuple of str
        What a student should know (limits narrowed to a stop, a re-homed servo).
    """

    name: str
    id: int
    zero: int
    direction: int
    limits: tuple
    zero_before: float
    direction_before: int
    limits_before: tuple
    swept: tuple | None
    offset_before: int
    offset: int | None
    notes: tuple = ()


@dataclass(frozen=True)
class BusCalibration:
    """The result of a guided calibration: one :class:`JointBusCalibration` per joint.

    Attributes
    ----------
    robot : str
        The robot's name.
    joints : tuple of JointBusCalibration
    path : str or None
        The robot file written (:func:`labkit.arm.calibrate_bus`), ``None`` if none was.
    backup : str or None
        The old file kept, ``None`` if none was.
    diff : str
        The lines of the robot file that changed (a unified diff), ``""`` if none was written.
    """

    robot: str
    joints: tuple
    path: str | None = None
    backup: str | None = None
    diff: str = ""

    def changes(self):
        """The robot-file changes, one dict per joint (:func:`labkit.robot.edit_bus_calibration`).

        Returns
        -------
        list of dict
        """
        return [{"zero": c.zero, "direction": c.direction, "limits": c.limits} for c in self.joints]

    def table(self):
        """Before and after, one line per joint, as text (angles in degrees).

        Returns
        -------
        str
        """
        def lim(v):
            return f"{math.degrees(v[0]):.1f}..{math.degrees(v[1]):.1f}"

        rows = [("joint", "id", "zero [ticks]", "direction", "limits [deg]", "homing offset [ticks]")]
        for c in self.joints:
            rows.append((c.name, str(c.id), f"{c.zero_before:g} -> {c.zero}", f"{c.direction_before:+d} -> {c.direction:+d}",
                         f"{lim(c.limits_before)} -> {lim(c.limits)}",
                         f"{c.offset_before} -> {c.offset}" if c.offset is not None else f"{c.offset_before} (kept)"))
        widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
        lines = ["  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]
        notes = [f"{c.name}: {note}" for c in self.joints for note in c.notes]
        return "\n".join(lines + notes)


def _wrap(delta, resolution):
    """``delta`` [ticks] into ``-resolution/2 .. resolution/2``."""
    return (delta + resolution // 2) % resolution - resolution // 2


def unwrap_ticks(ticks, resolution, start=None):
    """Readings of a one-turn encoder as a continuous path [ticks], relative to ``start``.

    Parameters
    ----------
    ticks : array_like of int, shape (k,)
        Successive present positions ``0 .. resolution - 1`` (each less than half a turn from the last).
    resolution : int
        Ticks per turn.
    start : int, optional
        Where the path starts from (default the first reading).

    Returns
    -------
    ndarray of int, shape (k,)
        Ticks turned since ``start``, the seam's jumps removed.

    Examples
    --------
    >>> unwrap_ticks([4090, 4095, 3, 10], 4096).tolist()
    [0, 5, 9, 16]
    """
    t = np.asarray(ticks, dtype=np.int64).reshape(-1)
    if t.size == 0:
        return t
    first = 0 if start is None else _wrap(int(t[0]) - int(start), resolution)
    steps = _wrap(np.diff(t), resolution)
    return np.concatenate([[first], first + np.cumsum(steps)])


def _fits(a, b, resolution):
    return round(a) >= 0 and round(b) <= resolution - 1


def _rehome(name, a, b, offset, resolution, homing, rehome):
    """The shift [ticks] that puts ``a .. b`` inside one turn, and the homing offset that makes it."""
    how = (f"set servo's homing offset so that the middle of the joint's range reads {resolution // 2} (Dynamixel "
           f"Wizard 2.0, Feetech FD, LeRobot's calibration) or remount the horn so the range does not cross tick "
           f"{resolution - 1} -> 0, then calibrate again")
    where = f"joint {name!r}: its limits map to ticks {a:.0f}..{b:.0f}, across the encoder's seam ({resolution - 1} -> 0)"
    if b - a >= resolution:
        raise BusCalibrationError(f"{where} and span more than one turn ({b - a:.0f} ticks): narrow the limits")
    if not rehome or homing is None:
        why = "rehome=False" if not rehome else "this bus has no homing-offset register in labkit's codec"
        raise BusCalibrationError(f"{where}; labkit does not write the offset ({why}): {how}")
    sign, limit = homing
    ideal = (resolution - 1) / 2 - (a + b) / 2
    lo, hi = math.ceil(-a - 0.5), math.floor(resolution - 1 - b + 0.5)  # every shift that keeps it inside
    for shift in sorted(range(lo, hi + 1), key=lambda s: (abs(s - ideal), s)):
        new = offset + sign * shift  # as is where the servo takes it (a Dynamixel's present counts on past a turn)
        if abs(new) > limit:
            new = _wrap(new, resolution)  # a whole turn less: the same reading on a servo that reads one turn
        if abs(new) <= limit and _fits(a + shift, b + shift, resolution):
            return shift, new
    raise BusCalibrationError(f"{where}, and no homing offset within the servo's +-{limit} ticks brings it inside "
                              f"one turn: {how}")


def solve_joint(robot, j, zero_tick, path, plus_end, *, offset=0, homing=None, rehome=True,
                margin=math.radians(1.0), min_move=math.radians(5.0)):
    """One joint's calibration from the readings of its zero mark, its labelled move and its sweep.

    Parameters
    ----------
    robot : labkit.robot.Robot
        The robot file as it was (limits, servo id, old zero and direction).
    j : int
        The joint.
    zero_tick : int
        Present position at the zero mark [ticks].
    path : array_like of int, shape (k,)
        Present positions read from the zero mark on: the move towards + and the sweep [ticks].
    plus_end : int
        Index in ``path`` of the first reading after the move towards + ended.
    offset : int
        The servo's homing offset during the readings [ticks].
    homing : tuple of int, optional
        ``(sign, limit)`` of the bus's homing offset (``present = raw + sign * offset``, ``|offset| <= limit``);
        ``None``: the bus has none labkit can write.
    rehome : bool
        Write a homing offset when the range crosses the encoder's seam (else raise, saying how to re-home).
    margin : float
        How far inside a stop the hand met a limit is put [rad].
    min_move : float
        Smallest labelled move and smallest sweep on each side of zero accepted [rad].

    Returns
    -------
    JointBusCalibration

    Raises
    ------
    BusCalibrationError
        The labelled move or the sweep was too small, the zero mark is outside the range swept, the
        limits left are empty, or the range crosses the seam and cannot be re-homed.
    """
    lk = robot.links[j]
    res = robot.bus.resolution
    per_rad = res / (2 * math.pi)
    if not 0 <= zero_tick <= res - 1:
        raise BusCalibrationError(f"joint {lk.name!r}: its servo reads tick {zero_tick} at the zero mark, outside one turn "
                                  f"0..{res - 1}: set it to position mode (one turn) and its homing offset to 0 with "
                                  f"the vendor's tool, then calibrate again")
    u = unwrap_ticks(path, res, start=zero_tick)
    if not 0 <= plus_end < len(u):
        raise BusCalibrationError(f"joint {lk.name!r}: no reading after the move towards + (got {len(u)} readings)")
    moved = int(u[plus_end])
    if abs(moved) < min_move * per_rad:
        raise BusCalibrationError(f"joint {lk.name!r}: the move towards + turned the servo {moved} ticks "
                                  f"({math.degrees(moved / per_rad):.1f} deg); expected at least "
                                  f"{math.degrees(min_move):.0f} deg: move it further from the zero mark, towards +")
    direction = 1 if moved > 0 else -1
    v = direction * u
    lo_t, hi_t = int(v.min()), int(v.max())
    notes = []
    if hi_t - lo_t >= FULL_TURN * res:
        swept = None
        lo, hi = lk.limits
        notes.append("turns a full turn (no stop met): the file's limits kept")
    else:
        swept = (lo_t / per_rad, hi_t / per_rad)
        if swept[0] > -min_move or swept[1] < min_move:
            raise BusCalibrationError(f"joint {lk.name!r}: the sweep went {math.degrees(swept[0]):.1f}.."
                                      f"{math.degrees(swept[1]):.1f} deg from the zero mark; expected at least "
                                      f"{math.degrees(min_move):.0f} deg on both sides: move it from stop to stop")
        lo, hi = max(lk.limits[0], swept[0] + margin), min(lk.limits[1], swept[1] - margin)
        for side, mine, theirs in (("lower", lo, lk.limits[0]), ("upper", hi, lk.limits[1])):
            if mine != theirs:
                notes.append(f"{side} limit {math.degrees(theirs):.1f} -> {math.degrees(mine):.1f} deg: the joint stops "
                             f"before the file's limit ({math.degrees(margin):g} deg kept from the stop)")
    if not lo < 0 < hi:
        raise BusCalibrationError(f"joint {lk.name!r}: the limits left, {math.degrees(lo):.1f}..{math.degrees(hi):.1f} "
                                  f"deg, do not contain the zero mark; check the mark and sweep again")
    a, b = sorted(zero_tick + direction * q * per_rad for q in (lo, hi))
    shift, new_offset = 0, None
    if not _fits(a, b, res):
        shift, new_offset = _rehome(lk.name, a, b, offset, res, homing, rehome)
        notes.append(f"range crossed the encoder's seam: homing offset {offset} -> {new_offset} ticks "
                     f"(its readings shift by {shift:+d} ticks)")
    return JointBusCalibration(
        name=lk.name, id=lk.bus.id, zero=int(zero_tick + shift) % res, direction=direction,
        limits=(float(lo), float(hi)), zero_before=lk.bus.zero, direction_before=lk.bus.direction,
        limits_before=tuple(float(x) for x in lk.limits), swept=swept, offset_before=int(offset),
        offset=new_offset, notes=tuple(notes))


# -- on the bus ------------------------------------------------------------------------------------------
def _register(driver, servo_id, where, value=None):
    """Read (``value=None``) or write a register ``(address, size)`` of one servo, retried as the driver retries."""
    address, size = where
    packets, result = driver.packets, None
    for _ in range(driver.retries + 1):
        if value is None:
            fn = {1: packets.read1ByteTxRx, 2: packets.read2ByteTxRx, 4: packets.read4ByteTxRx}[size]
            data, result, _error = fn(driver.handler, servo_id, address)
        else:
            fn = {1: packets.write1ByteTxRx, 2: packets.write2ByteTxRx, 4: packets.write4ByteTxRx}[size]
            data = None
            result, _error = fn(driver.handler, servo_id, address, int(value) & ((1 << 8 * size) - 1))
        if result == driver.sdk.COMM_SUCCESS:
            return data
    what = "reading" if value is None else "writing"
    raise BusFault(f"{driver.name}: {what} register {address} of {driver.servo(servo_id)} failed: "
                   f"{driver._comm(result)}")


def offset_from_register(codec, value):
    """The homing offset [ticks] a register value of bus ``codec`` means (sign-magnitude or two's complement).

    Parameters
    ----------
    codec : module
        A bus codec module with ``HOMING_OFFSET`` and ``HOMING_SIGN_BIT``.
    value : int
        The register's bytes as an unsigned number.

    Returns
    -------
    int
    """
    size = codec.HOMING_OFFSET[1]
    if codec.HOMING_SIGN_BIT is not None:
        magnitude = value & ((1 << codec.HOMING_SIGN_BIT) - 1)
        return -magnitude if value >> codec.HOMING_SIGN_BIT & 1 else magnitude
    return value - (1 << 8 * size) if value >> (8 * size - 1) else value


def offset_to_register(codec, offset):
    """The register value (unsigned) that holds homing offset ``offset`` [ticks] on bus ``codec``.

    Parameters
    ----------
    codec : module
    offset : int

    Returns
    -------
    int
    """
    if codec.HOMING_SIGN_BIT is not None:
        return abs(offset) | (1 << codec.HOMING_SIGN_BIT if offset < 0 else 0)
    return offset


def _write_offset(driver, codec, servo_id, offset):
    lock = codec.EEPROM_LOCK
    if lock is not None:
        _register(driver, servo_id, lock, 0)
    _register(driver, servo_id, codec.HOMING_OFFSET, offset_to_register(codec, offset))
    if lock is not None:
        _register(driver, servo_id, lock, 1)


class _Sampler:
    """Reads every servo's present position in a thread, every ``period`` seconds, until stopped."""

    def __init__(self, driver, period):
        self.driver = driver
        self.period = period
        self.ticks = []
        self.error = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="labkit bus calibration", daemon=True)
        self._thread.start()

    def _run(self):
        try:
            while not self._stop.is_set():
                self.ticks.append(self.driver.read_state().ticks.copy())
                self._stop.wait(self.period)
        except Exception as exc:  # noqa: BLE001 - raised again in the caller's thread
            self.error = exc

    def mark(self, timeout=5.0):
        """Index of the first reading taken wholly after this call (waits for it)."""
        count = len(self.ticks)
        deadline = time.monotonic() + timeout
        while len(self.ticks) < count + 2 and self.error is None and self._thread.is_alive():
            if time.monotonic() > deadline:
                raise BusFault(f"{self.driver.name}: no present-position reading within {timeout:g} s")
            time.sleep(0.001)
        if self.error is not None:
            raise self.error
        return count + 1

    def stop(self):
        """Stop after one more reading; return all readings, shape (k, n)."""
        end = self.mark()
        self._stop.set()
        self._thread.join(5.0)
        return np.array(self.ticks[:end + 1])


def _prompts(robot, j):
    lk = robot.links[j]
    who = f"joint {j + 1}/{robot.n} {lk.name!r} (servo {lk.bus.id})"
    lo, hi = (math.degrees(v) for v in lk.limits)
    return {
        "zero": f"{who}: move it to its zero mark (q = 0 of the robot file) and let go; press Enter",
        "plus": f"{who}: move it 10-30 deg towards + (the joint's positive sense, as the robot file's q); press Enter",
        "range": f"{who}: move it slowly to one stop, then to the other (the file says {lo:.0f}..{hi:.0f} deg), "
                 f"then back near zero; press Enter",
    }


def calibrate_servos(robot, device, *, ask, say=print, rehome=True, margin=math.radians(1.0),
                     min_move=math.radians(5.0), period=0.005, latency=None, name=None, write_offsets=True):
    """Guide a student through each joint of a bus arm with torque off and compute its calibration.

    Parameters
    ----------
    robot : Robot or str
        The robot (file) with a ``[bus]`` table: servo ids, limits, the old zeros and directions.
    device : str
        The bus adapter's serial device, or a :class:`BusEmulator`'s ``path``.
    ask : callable
        ``ask(step)`` with a :class:`CalibrationStep`: returns when the student has done it.
    say : callable
        ``say(text)`` for progress lines (default ``print``).
    rehome : bool
        Write a servo's homing offset when its range crosses the encoder's seam (else
        :class:`BusCalibrationError` saying how to re-home).
    margin : float
        Limits put this far inside a stop the hand met [rad].
    min_move : float
        Smallest labelled move and sweep on each side accepted [rad].
    period : float
        Time between two readings while the student moves a joint [s].
    latency : float, optional
        The adapter's latency in the SDK's timeouts [ms] (:class:`BusDriver`).
    name : str, optional
        How messages name the bus.
    write_offsets : bool
        ``False``: compute the homing offsets a range across the seam needs but write nothing to the servos (a dry
        run: the zeros are then those the servos will read once the offsets are written).

    Returns
    -------
    BusCalibration

    Raises
    ------
    OptionError
        The robot has no ``[bus]`` table.
    BusCalibrationError
        A step was not done as asked (the message says what to redo).
    DeviceError
        The bus cannot be opened, a servo does not answer, the servo did not take its homing offset.
    """
    robot = Robot.load(robot)
    if robot.bus is None:
        raise OptionError(f"expected a robot file with a [bus] table to calibrate its servos, got {robot.name!r}")
    if not callable(ask) or not callable(say):
        raise OptionError(f"expected ask and say as functions, got {ask!r} and {say!r}")
    codec = bus_module(robot.bus.protocol)
    has_homing = getattr(codec, "HOMING_OFFSET", None) is not None
    homing = (codec.HOMING_SIGN, codec.HOMING_LIMIT) if has_homing else None
    driver = codec.Driver(robot, device, name=name, latency=latency)
    try:
        driver.ping_all()
        driver.torque(False)
        offsets = [offset_from_register(codec, _register(driver, i, codec.HOMING_OFFSET)) if has_homing else 0
                   for i in driver.ids]
        say(f"{driver.name}: {robot.n} servos answer; torque is off: move each joint by hand when asked")
        joints = []
        for j in range(robot.n):
            texts = _prompts(robot, j)

            def step(kind):
                ask(CalibrationStep(j, robot.links[j].name, kind, texts[kind]))

            step("zero")
            zero_tick = int(np.median([driver.read_state().ticks[j] for _ in range(3)]))
            say(f"  {robot.links[j].name}: zero mark at tick {zero_tick}")
            sampler = _Sampler(driver, period)
            try:
                step("plus")
                plus_end = sampler.mark()
                step("range")
            finally:
                path = sampler.stop()
            cal = solve_joint(robot, j, zero_tick, path[:, j], plus_end, offset=offsets[j], homing=homing,
                              rehome=rehome, margin=margin, min_move=min_move)
            if cal.offset is not None and not write_offsets:
                cal = replace(cal, notes=cal.notes + ("the homing offset was not written (dry run)",))
            elif cal.offset is not None:
                before = int(driver.read_state().ticks[j])
                _write_offset(driver, codec, cal.id, cal.offset)
                after = int(driver.read_state().ticks[j])
                want = (before + _wrap(codec.HOMING_SIGN * (cal.offset - offsets[j]), robot.bus.resolution)) \
                    % robot.bus.resolution
                if abs(_wrap(after - want, robot.bus.resolution)) > 2:
                    raise BusFault(f"{driver.name}: {driver.servo(cal.id)} reads {after} after its homing offset was "
                                   f"set to {cal.offset} (expected {want}): is its EEPROM locked? hold the joint still "
                                   f"and calibrate again")
            span = "a full turn" if cal.swept is None else \
                f"{math.degrees(cal.swept[0]):.1f}..{math.degrees(cal.swept[1]):.1f} deg"
            say(f"  {cal.name}: direction {cal.direction:+d}, swept {span}, zero tick {cal.zero}"
                + "".join(f"; {note}" for note in cal.notes))
            joints.append(cal)
    finally:
        driver.close()
    return BusCalibration(robot.name, tuple(joints))
