"""The virtual arm: a pure-Python board speaking ``docs/protocol.md`` (version 3).

:class:`VirtualBoard` is hobby servos (and ideal actuators on the joints without a servo) and their simulated physics (:class:`labkit.arm.ArmModel`)
behind the board's firmware, an :class:`Executor` it holds (``board.executor``: segment queue,
servo frames, feedback stream, host-silence timeout, virtual EEPROM; ``_executor.py`` and
``_commands.py``); the wire format (checksum, error codes, line limit) is in ``_protocol.py``,
shared with the host. The board turns the executor's commanded joints into servo pulses, its
``READ`` and ``FB`` frames into the feedback pots' counts. It is byte-level and clocked explicitly: :meth:`VirtualBoard.receive` feeds bytes from the
host, :meth:`VirtualBoard.advance_to` moves board time forward (emitting
servo frames, ``FB`` frames and events at their exact times), and
:meth:`VirtualBoard.take_output` returns the bytes the board sent.

Reach it as ``serial.serial_for_url("sim://...")`` (see
:mod:`labkit.arm.urlhandler.protocol_sim`) or serve it on a pseudo-terminal with
``labkit sim`` for any serial tool.

Examples
--------
>>> board = VirtualBoard("arduino_arm_3dof")
>>> board.advance_to(0.2)
>>> board.take_output().split(b" ")[:3]
[b'READY', b'labkit-arm', b'3']
>>> board.receive(b"#7 PING\\n")
>>> board.take_output()
b'OK #7 PING 200*B63589B2\\r\\n'
"""

from __future__ import annotations

import math

from labkit.robot import Robot
from labkit.arm._protocol import WireUnits, cdeg, wire_calibrations, wire_speed_limits
from labkit.arm._actuator import is_ideal, joint_sensor
from labkit.arm.board._physics import PhysicsConfig
from labkit.arm.board._model import ArmModel
from labkit.arm.board._commands import FACTORY, eeprom_image
from labkit.arm.board._executor import Executor

__all__ = ["VirtualBoard"]


def calibration_rows(robot):
    """The board calibration ``[pmin, pmax, zero, direction, lo, hi]`` of every channel of ``robot``.

    The rows :meth:`labkit.arm.Arm.sync_calibration` sends with ``CAL``: the pulse widths at
    the ends of the servo's travel (a hobby servo's 0 and 180 deg, an RC linear servo's stroke) [us],
    the servo position at ``q = 0`` and the joint limits [wire units: cdeg, or 1/18000 of a linear
    servo's stroke] (:func:`labkit.arm.wire_calibrations`). Joints without a servo and the
    gripper channel keep the factory row (the gripper: its pulse range).

    Parameters
    ----------
    robot : Robot or str
        The robot (file).

    Returns
    -------
    list of list of int
        ``robot.n + 1`` rows (joints, then the gripper channel).
    """
    robot = Robot.load(robot)
    joints, gripper = wire_calibrations(robot)
    rows = [list(FACTORY) if row is None else row for row in joints] + [list(FACTORY) if gripper is None else gripper]
    return rows


class VirtualBoard:
    """Protocol-v3 board with simulated hobby servos (see the module notes).

    Parameters
    ----------
    robot : Robot or str
        The arm (its servo calibrations are the *true* servos of the physics).
    config : PhysicsConfig
        Physics parameters and seed.
    queue : int
        Segment queue depth reported by ``HELLO``.
    user_pot : int
        ADC counts of the user potentiometer on A5 (settable attribute).
    saved_calibration : bool
        Boot with the robot file's calibration already in EEPROM (``CAL`` + ``SAVE``).

    Attributes
    ----------
    executor : Executor
        The board's firmware: its state (``q``, ``cal``, ``segments``, ``done`` ...), commands and clock.
    model : ArmModel
        The physics (offsets, sag, ruler: ``board.model.ruler(3)``).
    sent_frames : dict
        ``{counter: (t_ms, adc tuple)}`` of the last ``FB`` frames emitted
        (ground truth for fault tests; keeps the last 100,000).
    pulses : dict
        Servo pulse widths now ``{channel: us}``; ``pulse_log`` their changes ``[(t, channel, us)]``.
    """

    #: the gripper servo is driven (``GRIP`` checked against its pulse range)
    grip_refused = ""

    def __init__(self, robot, config=PhysicsConfig(), *, queue=6, user_pot=512,
                 saved_calibration=False):
        self.robot = Robot.load(robot)
        #: joints without a servo: ideal actuators over the robot file's limits (``labkit.arm``'s ``_actuator``)
        self._ideal = [is_ideal(lk) for lk in self.robot.links]
        for j in range(self.robot.n):
            if self._ideal[j]:
                joint_sensor(self.robot, j)  # refuses infinite limits
        self._ideal_range = [tuple(cdeg(v) for v in lk.limits) if ideal else None
                             for lk, ideal in zip(self.robot.links, self._ideal)]
        self.user_pot = int(user_pot)
        self.config = config
        eeprom = bytearray(b"\xff" * 1024)
        if saved_calibration:  # a board whose EEPROM already holds the robot file's calibration (CAL + SAVE)
            img = eeprom_image(calibration_rows(self.robot), *wire_speed_limits(self.robot), 500)
            eeprom[: len(img)] = img
        self.sent_frames = {}
        #: analog pins forced to a voltage (``set_analog``), overriding the physics
        self.analog_override = {}
        self.pulses = {}
        self.pulse_log = []
        self.model = None
        self.executor = Executor(self, self.robot.n, queue=queue, eeprom=eeprom)
        self.executor.boot("POWER")

    # -- what a port drives (labkit.arm.urlhandler) ---------------------------------------
    @property
    def time(self):
        """Board time [s] since power-up."""
        return self.executor.time

    @property
    def clock_ms(self):
        """Board clock [ms since the last boot] (uint32)."""
        return self.executor.clock_ms

    @property
    def out_waiting(self):
        """Number of bytes sent by the board and not yet taken."""
        return self.executor.out_waiting

    def receive(self, data):
        """Bytes arriving from the host at the current board time (see :meth:`Executor.receive`).

        Parameters
        ----------
        data : bytes-like
        """
        self.executor.receive(data)

    def take_output(self, size=None):
        """Remove and return up to ``size`` bytes the board has sent (all if ``None``).

        Parameters
        ----------
        size : int, optional

        Returns
        -------
        bytes
        """
        return self.executor.take_output(size)

    def next_event_time(self):
        """Board time [s] of the next scheduled activity (boot, servo frame or ``FB`` frame).

        Returns
        -------
        float
        """
        return self.executor.next_event_time()

    def advance_to(self, t):
        """Run the board until board time ``t`` [s], emitting what falls due.

        Parameters
        ----------
        t : float
            Board time to reach [s] (no-op for the past).
        """
        self.executor.advance_to(t)

    def advance(self, dt):
        """Run the board for ``dt`` seconds of board time.

        Parameters
        ----------
        dt : float
            Board time to run [s].
        """
        self.executor.advance_to(self.executor.time + dt)

    def reset(self, reason="EXTERNAL"):
        """Reset the MCU (as DTR on open does): RAM state lost, EEPROM kept, ``READY`` 0.1 s later.

        Parameters
        ----------
        reason : str
            Reset cause reported in ``READY ... reset=<reason>``.
        """
        self.executor.boot(reason)

    @property
    def virtual_model(self):
        """The simulated arm (:class:`ArmModel`)."""
        return self.model

    def read_servos(self):
        """``None``: hobby servos report their joints only through the feedback pots (``READ``, ``FB``).

        Returns
        -------
        None
        """
        return None

    def servo_bus(self):
        """``None``: hobby servos have no bus to reach (:meth:`labkit.arm.BoardPort.servo_bus`).

        Returns
        -------
        None
        """
        return None

    def servo_stream(self):
        """``None``: stream frames are sent as ``FB`` lines.

        Returns
        -------
        None
        """
        return None

    def shutdown(self):
        """Nothing to release (the port's ``close`` calls it)."""

    def set_analog(self, pin, volts):
        """Force analog pin ``pin`` (0..5) to ``volts`` (``None`` returns it to the physics).

        Parameters
        ----------
        pin : int
            Analog input number, 0..5.
        volts : float or None
            Voltage the pin reads [V]; ``None`` removes the override.
        """
        if volts is None:
            self.analog_override.pop(int(pin), None)
        else:
            self.analog_override[int(pin)] = float(volts)

    # -- the hobby servos: what the executor asks (its Servos interface) ----------------------
    def joint_range(self, j, cal):
        """Joint ``j``'s feasible range ``lo, hi`` [cdeg]: its limits within its servo's 0..180 deg.

        An ideal actuator (a joint without a servo in the robot file) ranges over the robot
        file's limits; its channel's calibration row is not used.

        Parameters
        ----------
        j : int
        cal : sequence of int
            The channel's calibration row.

        Returns
        -------
        tuple of int
        """
        if self._ideal[j]:
            return self._ideal_range[j]
        zero, direction, lo, hi = cal[2:6]
        a, b = (-zero, 18000 - zero) if direction > 0 else (zero - 18000, zero)
        return max(a, lo), min(b, hi)

    def valid(self, j, q, cal):
        """Whether ``q`` [cdeg] is within joint ``j``'s limits and its servo's 0..180 deg.

        Parameters
        ----------
        j : int
        q : float
        cal : sequence of int

        Returns
        -------
        bool
        """
        if self._ideal[j]:
            lo, hi = self._ideal_range[j]
            return lo <= q <= hi
        s = cal[2] + cal[3] * q
        return cal[4] <= q <= cal[5] and 0 <= s <= 18000

    def clamp(self, j, q, cal):
        """``q`` [cdeg] clamped to joint ``j``'s limits, then to its servo's 0..180 deg.

        Parameters
        ----------
        j : int
        q : float
        cal : sequence of int

        Returns
        -------
        float
        """
        if self._ideal[j]:
            lo, hi = self._ideal_range[j]
            return min(max(q, lo), hi)
        lo, hi = cal[4], cal[5]
        q = min(max(q, lo), hi)
        s = cal[2] + cal[3] * q
        if s < 0 or s > 18000:
            q = (min(max(s, 0), 18000) - cal[2]) * cal[3]
        return q

    def power_up(self):
        """At power-up the arm rests at the boot position; a reset keeps it where it is."""
        if self.model is None:
            self.model = ArmModel(self.robot, self.config, q0=WireUnits(self.robot).joints(self.executor.q))

    def settle(self):
        """Run the physics up to board time."""
        self.model.advance_to(self.executor.time)

    def frame(self):
        """A servo frame: the commanded joints and the gripper as pulse widths, to the physics."""
        ex = self.executor
        t = ex.time
        self.model.advance_to(t)
        # hobby servos get pulses; an ideal actuator (no servo) gets its joint value [cdeg -> rad | m]
        pulses = {j: _pulse(ex.cal[j], ex.cal[j][2] + ex.cal[j][3] * ex.q[j]) for j in range(ex.joints)
                  if not self._ideal[j]}
        pulses[ex.joints] = float(ex.grip)
        for ch, us in pulses.items():
            if self.pulses.get(ch) != us:
                self.pulse_log.append((t, ch, us))
        if len(self.pulse_log) > 200_000:
            del self.pulse_log[:100_000]
        self.pulses = pulses
        self.model.command_pulses(pulses)
        if any(self._ideal):
            self.model.command_joints({j: math.radians(ex.q[j] / 100.0) for j in range(ex.joints) if self._ideal[j]})

    def feedback(self):
        """The feedback pots' counts now (joints, then the user pot), analog overrides applied.

        Returns
        -------
        list of int
        """
        joints = self.executor.joints
        self.model.advance_to(self.executor.time)
        counts = [int(a) for a in self.model.feedback_adc()] + [self.user_pot]
        for k, pin in enumerate([*range(joints), 5]):
            if pin in self.analog_override:
                counts[k] = min(max(int(math.floor(self.analog_override[pin] * 1024 / 5.0)), 0), 1023)
        return counts

    def stream_frame(self, counter, t_ms):
        """An ``FB`` frame's counts (kept in :attr:`sent_frames`).

        Parameters
        ----------
        counter : int
        t_ms : int

        Returns
        -------
        list of int
        """
        adc = self.feedback()
        self.sent_frames[counter] = (t_ms, tuple(adc))
        if len(self.sent_frames) > 100_000:
            self.sent_frames.pop(next(iter(self.sent_frames)))
        return adc

    def stream_rate(self, hz):
        """Nothing to prepare: frames are sent as ``FB`` lines.

        Parameters
        ----------
        hz : int
            Frame rate [Hz], 0: off.
        """


def _pulse(cal, servo_cdeg):
    """The pulse width [us, to 0.5 us] of servo angle ``servo_cdeg`` under calibration row ``cal``."""
    return round((cal[0] + servo_cdeg * (cal[1] - cal[0]) / 18000.0) * 2) / 2
