"""The virtual servos' hardware: how each horn is mounted, its homing offset, and a hand that moves a joint.

A robot file says where each servo reads zero and which way it turns; a real arm is assembled
with its horns wherever they went on the splines. :class:`VirtualServo` is that truth for one
joint of a :class:`BusEmulator`: the raw encoder tick at the joint's zero, the servo's sense, and
the mechanical stops a hand meets. The encoder reads one turn, ``0 .. resolution - 1``, and wraps at
the seam; the servo's homing-offset register (Dynamixel address 20, Feetech ``Ofs`` at 31, the codec
module's ``HOMING_OFFSET``) shifts what it reports: ``present = raw + HOMING_SIGN * offset`` (mod one
turn). A goal position moves the shaft by ``goal - present`` ticks (position mode: the servo never
crosses its seam).

:class:`VirtualHand` is the student of a guided calibration on the virtual bus: with torque off it
moves a joint to an angle (stopping at the stops), sweeps it through its range, and answers each
calibration step (:func:`labkit.arm.bus.calibrate_servos`) as a person following the prompts would.

Examples
--------
>>> import numpy as np
>>> from labkit.robot import Robot
>>> robot = Robot.load("so101")
>>> servos = assembled_servos(robot, seed=1, seam=(2,))
>>> servos[2].crosses_seam(robot.links[2].limits, 4096), servos[1].crosses_seam(robot.links[1].limits, 4096)
(True, False)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import BusFault, OptionError
from labkit.arm.bus._calibrate import offset_from_register

__all__ = ["VirtualServo", "VirtualHand", "assembled_servos", "homing_offset", "present_ticks", "goal_joint"]

#: how far past a joint's limits the virtual arm's mechanical stops are, by default [rad]
STOP_MARGIN = math.radians(3.0)


@dataclass(frozen=True)
class VirtualServo:
    """How one joint's servo is really mounted on a virtual arm.

    Attributes
    ----------
    zero : float
        Raw encoder position at the joint's zero [ticks], before the homing offset (taken modulo one turn).
    direction : int
        +1 when the encoder counts up as the joint turns positive, else -1.
    stops : tuple of float
        ``(lower, upper)`` mechanical stops of the joint [rad]; a hand cannot move it past them.
    """

    zero: float
    direction: int
    stops: tuple

    def __post_init__(self):
        if self.direction not in (1, -1):
            raise OptionError(f"VirtualServo: expected direction 1 or -1, got {self.direction!r}")
        lo, hi = (float(v) for v in self.stops)
        if not (math.isfinite(self.zero) and math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise OptionError(f"VirtualServo: expected a finite zero and finite stops lower < upper, "
                              f"got zero {self.zero!r}, stops {self.stops!r}")
        object.__setattr__(self, "stops", (lo, hi))

    def raw(self, q, resolution):
        """Raw encoder reading [ticks, not wrapped, not rounded] at joint value ``q`` [rad].

        Parameters
        ----------
        q : float
            Joint value [rad].
        resolution : int
            Ticks per turn.

        Returns
        -------
        float
        """
        return self.zero + self.direction * q * resolution / (2 * math.pi)

    def crosses_seam(self, limits, resolution):
        """Whether the encoder wraps (tick ``resolution - 1`` -> 0) between ``limits`` (no homing offset).

        Parameters
        ----------
        limits : tuple of float
            ``(lower, upper)`` joint values [rad].
        resolution : int
            Ticks per turn.

        Returns
        -------
        bool
        """
        ends = [math.floor(self.raw(q, resolution) / resolution) for q in limits]
        return ends[0] != ends[1]


def assembled_servos(robot, seed=None, *, seam=()):
    """The servos of an arm as assembled: every horn somewhere, some servos turning the other way.

    Parameters
    ----------
    robot : labkit.robot.Robot
        A robot with a ``[bus]`` table.
    seed : int, optional
        Random mounting; ``None``: the robot file's own ``zero`` and ``direction`` (a calibrated arm).
    seam : sequence of int or str
        Joints (index or name) mounted so that the encoder's seam falls inside their limits (it needs a
        homing offset); the others are mounted so that it does not, where their limits leave room.

    Returns
    -------
    tuple of VirtualServo, shape (n,)
        Stops :data:`STOP_MARGIN` past each joint's limits.
    """
    res = robot.bus.resolution
    names = list(robot.joint_names)
    seam = {names.index(s) if isinstance(s, str) and s in names else s for s in seam}
    bad = [s for s in seam if not (isinstance(s, (int, np.integer)) and 0 <= s < robot.n)]
    if bad:
        raise OptionError(f"expected seam joints as indices 0..{robot.n - 1} or names {names}, got {bad[0]!r}")
    rng = None if seed is None else np.random.default_rng(seed)
    out = []
    for j, lk in enumerate(robot.links):
        lo, hi = lk.limits
        stops = (lo - STOP_MARGIN, hi + STOP_MARGIN)
        if rng is None:
            out.append(VirtualServo(float(lk.bus.zero), lk.bus.direction, stops))
            continue
        direction = int(rng.choice([1, -1]))
        span = (hi - lo) * res / (2 * math.pi)
        # ticks of the lower limit's side below zero: raw(lo) = zero - below (direction +1)
        below = (-lo if direction == 1 else hi) * res / (2 * math.pi)
        if j in seam:  # the seam somewhere in the middle half of the range
            zero = below - span * rng.uniform(0.25, 0.75)
        else:
            room = res - 1 - span
            zero = below + (rng.uniform(0.1, 0.9) * room if room > 0 else 0.0)
        out.append(VirtualServo(float(round(zero) % res), direction, stops))
    return tuple(out)


def homing_offset(emulator, servo_id):
    """The homing offset servo ``servo_id`` of ``emulator`` holds [ticks] (0 on a bus without one).

    Parameters
    ----------
    emulator : BusEmulator
    servo_id : int

    Returns
    -------
    int
    """
    bus = emulator.bus
    where = getattr(bus, "HOMING_OFFSET", None)
    if where is None:
        return 0
    address, size = where
    return offset_from_register(bus, int.from_bytes(emulator.memory[servo_id][address:address + size], "little"))


def _shift(emulator, j):
    """What the homing offset adds to joint ``j``'s raw reading [ticks]."""
    bus = emulator.bus
    return getattr(bus, "HOMING_SIGN", 1) * homing_offset(emulator, emulator.ids[j])


def present_ticks(emulator, j, q):
    """The present position joint ``j``'s servo reports at joint value ``q`` [rad]: one turn, offset applied.

    Parameters
    ----------
    emulator : BusEmulator
    j : int
    q : float

    Returns
    -------
    int
        ``0 .. resolution - 1`` [ticks].
    """
    res = emulator.robot.bus.resolution
    return int(np.rint(emulator.hardware[j].raw(q, res) + _shift(emulator, j))) % res


def goal_joint(emulator, j, ticks):
    """Where joint ``j`` goes for goal position ``ticks``: the servo turns by ``goal - present`` ticks.

    Parameters
    ----------
    emulator : BusEmulator
    j : int
    ticks : int
        Goal position [ticks].

    Returns
    -------
    float
        Joint value [rad].
    """
    res = emulator.robot.bus.resolution
    servo = emulator.hardware[j]
    shift = _shift(emulator, j)
    turn = math.floor((servo.raw(float(emulator.model.shaft_q[j]), res) + shift) / res)  # the turn it reads in
    return float((ticks + turn * res - shift - servo.zero) * servo.direction * (2 * math.pi) / res)


class VirtualHand:
    """A scripted student's hand on a :class:`BusEmulator`: moves joints whose torque is off.

    Parameters
    ----------
    emulator : BusEmulator
    plus : float
        How far the hand turns a joint when asked to move it towards + [rad].
    step : float
        Largest move between two waypoints of a sweep [rad].
    reads : int
        Sync reads of the bus to wait for at each waypoint of a move that someone is recording.
    timeout : float
        Longest wait for those reads [s of wall time].
    """

    def __init__(self, emulator, *, plus=math.radians(20.0), step=math.radians(10.0), reads=1, timeout=5.0):
        self.emulator = emulator
        self.plus = float(plus)
        self.step = float(step)
        self.reads = int(reads)
        self.timeout = float(timeout)

    def _index(self, joint):
        names = list(self.emulator.robot.joint_names)
        if isinstance(joint, str) and joint in names:
            return names.index(joint)
        if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool) and 0 <= joint < len(names):
            return int(joint)
        raise OptionError(f"expected a joint index 0..{len(names) - 1} or a name of {names}, got {joint!r}")

    def position(self, joint):
        """Where joint ``joint`` is [rad].

        Parameters
        ----------
        joint : int or str

        Returns
        -------
        float
        """
        return float(self.emulator.model.shaft_q[self._index(joint)])

    def move(self, joint, q, *, reads=0):
        """Put joint ``joint`` at ``q`` [rad] by hand (stopped by its mechanical stops).

        Parameters
        ----------
        joint : int or str
        q : float
        reads : int
            Return once the bus has answered this many sync reads after the move.

        Raises
        ------
        OptionError
            The servo's torque is on (a hand cannot turn a servo that holds its position).
        BusFault
            Nobody read the bus within ``timeout``.
        """
        emu = self.emulator
        j = self._index(joint)
        lo, hi = emu.hardware[j].stops
        with emu._lock:
            if emu.torque(emu.ids[j]):
                raise OptionError(f"expected torque off on servo {emu.ids[j]} to move joint "
                                  f"{emu.robot.joint_names[j]!r} by hand, got torque on")
            q_all = emu.model.shaft_q
            q_all[j] = min(max(float(q), lo), hi)
            emu.model.servos.reset(q_all)
            seen = len(emu.packets)
        deadline = time.monotonic() + self.timeout
        while sum(1 for p in emu.packets[seen:] if p[0] == "sync read") < reads:
            if time.monotonic() > deadline:
                raise BusFault(f"virtual hand: {reads} sync read(s) of the bus expected within {self.timeout:g} s "
                               f"after moving joint {emu.robot.joint_names[j]!r}, got fewer")
            time.sleep(0.0005)

    def move_through(self, joint, targets):
        """Move joint ``joint`` through ``targets`` [rad] in steps of at most :attr:`step`, each step read.

        Parameters
        ----------
        joint : int or str
        targets : sequence of float
        """
        q = self.position(joint)
        for target in targets:
            k = max(1, math.ceil(abs(target - q) / self.step))
            for v in np.linspace(q, target, k + 1)[1:]:
                self.move(joint, float(v), reads=self.reads)
            q = self.position(joint)

    def answer(self, step):
        """Do what calibration step ``step`` asks, as a student would (zero mark, a move towards +, the range).

        Parameters
        ----------
        step : CalibrationStep
        """
        j = step.index
        lo, hi = self.emulator.hardware[j].stops
        if step.move == "zero":
            self.move(j, 0.0)
        elif step.move == "plus":
            self.move_through(j, [self.plus])
        elif step.move == "range":
            self.move_through(j, [hi, lo, 0.0])
        else:
            raise OptionError(f"expected a calibration step's move 'zero', 'plus' or 'range', got {step.move!r}")
