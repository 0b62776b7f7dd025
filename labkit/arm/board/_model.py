"""The virtual arm model and its adapter for the firmware harness.

:class:`ArmModel` is the whole simulated arm (servo dynamics, zero offsets,
gravity sag, pot feedback with noise, a ruler); the ``sim://`` virtual board
drives it, and :class:`FirmwareAdapter` drives the same model from the pulse
widths of the real firmware in simavr. A link reaches it as
:attr:`labkit.arm.Arm.virtual_model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.robot import Robot
from labkit.arm._actuator import is_ideal, joint_sensor
from labkit.arm.board._physics import ADC_MAX, ADC_VREF, PhysicsConfig, ServoBank, _per_joint, gravity_sag

__all__ = ["ArmModel", "FirmwareAdapter"]


@dataclass
class _Noise:
    feedback: np.random.Generator
    ruler: np.random.Generator


class ArmModel:
    """The whole virtual arm: servos, zero offsets, sag, feedback, ruler.

    Parameters
    ----------
    robot : Robot or str
        Robot (or bundled robot name) whose servo calibrations define the pulses and feedback.
    config : PhysicsConfig
    q0 : array_like, shape (n,), optional
        Initial shaft positions [rad].

    Attributes
    ----------
    zero_offsets : ndarray, shape (n,)
        Injected zero-offset errors [rad]: ``true joint = shaft + offset + sag``.

    Examples
    --------
    >>> arm = ArmModel("arduino_arm_3dof", PhysicsConfig(seed=0))
    >>> arm.command([0.0, 0.5, 0.0]); arm.advance(2.0)
    >>> p = arm.ruler(3)          # three readings [m], shape (3, 3)
    >>> p.shape
    (3, 3)
    """

    def __init__(self, robot, config=PhysicsConfig(), q0=None):
        self.robot = robot = Robot.load(robot)
        self.config = config
        self.servos = ServoBank(robot, config, q0)
        off_rng, fb_rng, ruler_rng = config.streams()
        if config.zero_offsets is not None:
            self.zero_offsets = _per_joint(config.zero_offsets, robot.n, "zero_offsets")
        else:
            self.zero_offsets = off_rng.normal(0.0, config.zero_offset_std, robot.n)
            # an ideal actuator (a joint without a servo) and a linear servo have no servo horn to mount one spline off
            self.zero_offsets[[is_ideal(lk) or not rev for lk, rev in zip(robot.links, robot.is_revolute)]] = 0.0
        self._noise = _Noise(fb_rng, ruler_rng)
        self._servo_cal = [lk.servo for lk in robot.links]
        #: the feedback of every joint: its servo's pot, or an ideal actuator's encoder (None on a servo bus)
        self._sensor = [None if lk.bus is not None else joint_sensor(robot, j) for j, lk in enumerate(robot.links)]
        #: joints driven as ideal actuators (commanded by joint value, :meth:`command_joints`)
        self.ideal = [is_ideal(lk) for lk in robot.links]

    @property
    def time(self):
        """Model time [s]."""
        return self.servos.time

    def command(self, q):
        """Command joint values ``q`` [rad], shape (n,) (clipped to the joint limits, as a servo would stop).

        Parameters
        ----------
        q : array_like, shape (n,)
            Commanded joint values [rad].
        """
        lim = self.robot.joint_limits
        self.servos.command(np.clip(np.asarray(q, dtype=float), lim[:, 0], lim[:, 1]))

    def command_pulses(self, pulses_us):
        """Command by pulse widths ``{channel: us}`` (channels without a joint are ignored).

        Parameters
        ----------
        pulses_us : mapping of int to float
            Servo channel -> pulse width [us]; joints whose channel is missing (or
            maps to None) keep their command.
        """
        q = self.servos.commanded
        for j, cal in enumerate(self._servo_cal):
            if cal is not None and cal.channel in pulses_us and pulses_us[cal.channel] is not None:
                q[j] = float(cal.joint_from_pulse(pulses_us[cal.channel]))
        self.command(q)

    def command_joints(self, q_by_joint):
        """Command some joints by value ``{joint index: q}`` [rad | m] (the ideal actuators' input).

        Parameters
        ----------
        q_by_joint : mapping of int to float
            Joint index -> commanded joint value; the other joints keep their command.
        """
        q = self.servos.commanded
        for j, v in q_by_joint.items():
            q[j] = float(v)
        self.command(q)

    def advance(self, duration):
        """Advance the physics by ``duration`` [s].

        Parameters
        ----------
        duration : float
            Time to simulate [s] (rounded to whole model steps).
        """
        self.servos.advance(duration)

    def advance_to(self, t):
        """Advance the physics to model time ``t`` [s].

        Parameters
        ----------
        t : float
            Model time to reach [s] (no-op if already there).
        """
        self.servos.advance_to(t)

    @property
    def shaft_q(self):
        """Servo shaft positions (what the pots measure, noise-free), shape (n,) [rad]."""
        return self.servos.position

    @property
    def true_q(self):
        """True joint values: shaft + zero offset + gravity sag, shape (n,) [rad]."""
        q = self.shaft_q + self.zero_offsets
        return q + gravity_sag(self.robot, q, self.config)

    def settled(self, **kwargs):
        """Whether the servos have settled (see :meth:`ServoBank.settled`).

        Parameters
        ----------
        **kwargs
            ``tol`` [rad] and ``speed`` [rad/s], passed to :meth:`ServoBank.settled`.

        Returns
        -------
        bool
        """
        return self.servos.settled(**kwargs)

    def feedback_adc(self):
        """Feedback ADC counts of every joint, shape (n,) (int, 0..1023; -1 for a bus servo).

        A servo's pot, or an ideal actuator's encoder over the joint limits. Each call draws
        fresh feedback noise.

        Returns
        -------
        ndarray of int, shape (n,)
            Counts 0..1023 (rounded, clipped), -1 for joints on a servo bus.
        """
        out = np.full(self.robot.n, -1, dtype=int)
        q = self.shaft_q
        for j, cal in enumerate(self._sensor):
            if cal is None:
                continue
            c = float(cal.adc_from_joint(q[j])) + self._noise.feedback.normal(0.0, self.config.feedback_noise)
            out[j] = int(min(max(round(c), 0), ADC_MAX))
        return out

    def feedback_volts(self):
        """Feedback voltages ``{channel: V}`` on the pot taps (noisy, quantised to the ADC).

        Returns
        -------
        dict of int to float
            Servo channel -> feedback voltage [V].
        """
        adc = self.feedback_adc()
        return {cal.channel: adc[j] * ADC_VREF / ADC_MAX for j, cal in enumerate(self._servo_cal) if cal is not None}

    def sensed_q(self):
        """Joint values sensed through the feedback ADC, shape (n,) [rad] (NaN on a servo bus).

        Returns
        -------
        ndarray, shape (n,)
            Sensed joint values [rad] (noisy, quantised).
        """
        adc = self.feedback_adc()
        return np.array(
            [float(cal.joint_from_adc(adc[j])) if cal is not None else math.nan for j, cal in enumerate(self._sensor)]
        )

    def end_effector(self):
        """True end-effector (tool point) position, shape (3,) [m].

        Returns
        -------
        ndarray, shape (3,)
            Tool position in the base frame at the true joint values [m].
        """
        from labkit.kinematics import fk_position

        return fk_position(self.robot, self.true_q)

    def ruler(self, readings=1):
        """Measure the end-effector with the ruler.

        Parameters
        ----------
        readings : int
            Number of repeated readings.

        Returns
        -------
        p : ndarray, shape (readings, 3)
            Readings [m]: true position plus reading noise, rounded to
            ``config.ruler_resolution``.
        """
        p = self.end_effector()
        noisy = p + self._noise.ruler.normal(0.0, self.config.ruler_noise, (int(readings), 3))
        res = self.config.ruler_resolution
        return np.round(noisy / res) * res if res > 0 else noisy


class FirmwareAdapter:
    """Physics for the firmware-in-the-loop harness (:mod:`labkit.arm`).

    The harness calls :meth:`on_tick` with the simulated time and the pulse
    widths the firmware currently outputs; the adapter converts them to
    commanded joints (``ServoCalibration.joint_from_pulse``), steps the same
    :class:`ArmModel` the virtual arm uses, and returns the feedback voltages
    (``ServoCalibration.adc_from_joint`` -> volts).

    Parameters
    ----------
    robot : Robot or str
    config : PhysicsConfig
    feedback_pins : dict, optional
        ``{servo channel: analog pin}`` where each joint's pot is wired
        (default: channel ``c`` on analog pin ``c``).
    q0 : array_like, shape (n,), optional
        Initial joints [rad] (default: the middle of the limits, the firmware's boot pose).

    Examples
    --------
    >>> fw = FirmwareAdapter("arduino_arm_3dof", PhysicsConfig(feedback_noise=0.0))
    >>> volts = fw.on_tick(0.02, {0: 1500.0, 1: 500.0, 2: 500.0})
    >>> sorted(volts)
    [0, 1, 2]
    """

    def __init__(self, robot, config=PhysicsConfig(), feedback_pins=None, q0=None):
        robot = Robot.load(robot)
        if q0 is None:  # where the firmware's boot pose puts the arm: the middle of the limits
            q0 = robot.joint_limits.mean(axis=1)
        self.model = ArmModel(robot, config, q0=q0)
        channels = [lk.servo.channel for lk in self.model.robot.links if lk.servo is not None]
        self.feedback_pins = dict(feedback_pins) if feedback_pins is not None else {c: c for c in channels}

    def on_tick(self, sim_time_s, pulses_us):
        """Step the physics to ``sim_time_s`` [s] under ``pulses_us`` ``{channel: us}``.

        Parameters
        ----------
        sim_time_s : float
            Simulated firmware time [s].
        pulses_us : mapping of int to float
            Latest servo pulse width per channel [us]; channels with no pulse
            (0 or None) keep their command.

        Returns
        -------
        dict
            ``{analog pin: volts}`` of the feedback pots.
        """
        self.model.command_pulses({int(k): v for k, v in pulses_us.items() if v})
        self.model.advance_to(float(sim_time_s))
        volts = self.model.feedback_volts()
        return {self.feedback_pins[c]: v for c, v in volts.items() if c in self.feedback_pins}
