"""Physics of the virtual arm: servo dynamics, gravity sag, offsets, noise, a ruler.

One model serves both simulated boards: the pure-Python virtual arm
(:mod:`labkit.sim`) and the firmware-in-the-loop harness
(:mod:`labkit.firmware_sim`, through :class:`FirmwareAdapter`, which only
supplies pulse widths and takes analog feedback voltages back).

Model, per joint ``j`` (see ``docs/virtual-arm.md``):

* the commanded joint value passes a **deadband** (the servo ignores a new
  command closer than ``deadband`` to where the shaft already is) and a
  **rate limit** (the reference moves at most ``rate_limit`` [rad/s]), then a
  **second-order transfer function** ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``
  built with :func:`control.tf` and discretised with
  :func:`control.sample_system` (zero-order hold, step ``dt``);
* the shaft position read by the servo's potentiometer is the model output;
  the **true joint** adds a per-joint **zero-offset** error (horn mounted one
  spline off, seeded) and the **gravity sag** of the links (joint compliance
  times the gravity torque, quasi-static; the pot does not see it);
* the **feedback** is the pot voltage as 10-bit ADC counts with Gaussian noise;
* the **ruler** returns the true end-effector position with reading noise,
  rounded to the ruler's resolution (seed 000: 0.5 mm).

Everything random is drawn from generators seeded by :attr:`PhysicsConfig.seed`
(independent streams for offsets, feedback noise and the ruler).

Coordinates: the base frame of the robot file. The seed 000 arm's base z axis
points **down** (its IK negates the user's Z; its shoulder sweeps over the top
through q2 = 90 deg at z = -0.274 m), so gravity is ``+z`` by default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from labkit.dh import Convention, Robot

__all__ = ["PhysicsConfig", "ServoBank", "ArmModel", "FirmwareAdapter", "gravity_sag", "ADC_VREF", "ADC_MAX"]

#: reference voltage and full scale of the board's 10-bit ADC (Arduino Uno)
ADC_VREF = 5.0
ADC_MAX = 1023


@dataclass(frozen=True)
class PhysicsConfig:
    """Parameters of the virtual arm's physics (all SI, frozen, seeded).

    Attributes
    ----------
    seed : int
        Seed of every random draw (offsets, feedback noise, ruler).
    dt : float
        Model step [s] (the servo transfer function is discretised with it).
    natural_frequency : float
        Closed-loop natural frequency of a servo [rad/s].
    damping_ratio : float
        Closed-loop damping ratio of a servo [1].
    rate_limit : float or None
        Largest reference speed [rad/s]; ``None`` uses each link's
        ``max_velocity`` (or 5.24 rad/s = 300 deg/s where unknown).
    deadband : float
        Servo deadband [rad] (about 5 us of pulse on a hobby servo).
    zero_offset_std : float
        Standard deviation of the random per-joint zero-offset errors [rad].
    zero_offsets : tuple of float or None
        Explicit zero-offset errors per joint [rad] (overrides the random ones).
    joint_compliance : float or tuple of float
        Joint compliance [rad/(N m)] (scalar or per joint).
    link_masses : tuple of float or None
        Mass of each moving link [kg], lumped at the middle of the link
        (``None``: 0.05 kg each).
    tool_mass : float
        Mass at the tool point (gripper with its servo) [kg].
    gravity : tuple of float
        Gravity in the robot's base frame [m/s^2] (default ``+z``, see module notes).
    feedback_noise : float
        Standard deviation of the feedback ADC noise [counts].
    ruler_resolution : float
        Ruler resolution [m]; readings are rounded to multiples of it.
    ruler_noise : float
        Standard deviation of a ruler reading before rounding [m].

    Examples
    --------
    >>> cfg = PhysicsConfig(seed=3, deadband=0.0)
    >>> cfg.ruler_resolution
    0.0005
    """

    seed: int = 0
    dt: float = 0.005
    natural_frequency: float = 25.0
    damping_ratio: float = 0.8
    rate_limit: float | None = None
    deadband: float = math.radians(0.45)
    zero_offset_std: float = math.radians(1.0)
    zero_offsets: tuple | None = None
    joint_compliance: float | tuple = 0.04
    link_masses: tuple | None = None
    tool_mass: float = 0.08
    gravity: tuple = (0.0, 0.0, 9.81)
    feedback_noise: float = 1.0
    ruler_resolution: float = 0.5e-3
    ruler_noise: float = 0.3e-3

    def __post_init__(self):
        for name in ("dt", "natural_frequency", "damping_ratio"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"expected {name} > 0, got {v!r}")
        for name in ("deadband", "zero_offset_std", "tool_mass", "feedback_noise", "ruler_resolution", "ruler_noise"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"expected {name} >= 0, got {v!r}")
        if self.rate_limit is not None and not self.rate_limit > 0:
            raise ValueError(f"expected rate_limit > 0 or None, got {self.rate_limit!r}")
        if len(self.gravity) != 3:
            raise ValueError(f"expected gravity with 3 components, got {self.gravity!r}")

    def streams(self):
        """Independent generators ``(offsets, feedback, ruler)`` for this seed.

        Returns
        -------
        tuple of numpy.random.Generator
            Three generators spawned from ``SeedSequence(seed)``: the same
            numbers on every call with the same seed.
        """
        return tuple(np.random.default_rng(s) for s in np.random.SeedSequence(self.seed).spawn(3))


def _per_joint(value, n, name):
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 else np.asarray(value, float)
    if arr.shape != (n,):
        raise ValueError(f"expected {name} as a scalar or {n} values, got shape {arr.shape}")
    return arr.copy()


def gravity_sag(robot, q, config=PhysicsConfig()):
    """Quasi-static joint deflection under gravity.

    Each link's mass sits at the middle of the link (between the origins of
    consecutive frames, the last link ending at the tool point, which also
    carries ``tool_mass``); the deflection of joint ``j`` is its compliance
    times the gravity torque about its axis.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m] (the pose that carries the load).
    config : PhysicsConfig

    Returns
    -------
    dq : ndarray, shape (..., n)
        Joint deflection [rad] (zero for prismatic joints).

    Examples
    --------
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> dq = gravity_sag(arm, [0.0, 0.0, 0.0])   # arm horizontal: the shoulder yields most
    >>> np.round(np.degrees(dq), 2)
    array([ 0.  , -0.75,  0.42])
    """
    from labkit.kinematics import fk_frames

    n = robot.n
    T = fk_frames(robot, q)  # (..., n + 2, 4, 4)
    origins = T[..., :3, 3]
    zs = T[..., :3, 2]
    masses = _per_joint(0.05 if config.link_masses is None else config.link_masses, n, "link_masses")
    compliance = _per_joint(config.joint_compliance, n, "joint_compliance")
    g = np.asarray(config.gravity, dtype=float)
    # joint j's axis: frame j (modified DH) or frame j-1 (standard DH)
    shift = 1 if robot.convention is Convention.MODIFIED else 0
    # link k (1..n) spans frame k -> frame k+1 (frame n+1 = tool)
    centres = 0.5 * (origins[..., 1:n + 1, :] + origins[..., 2:n + 2, :])
    tip = origins[..., n + 1, :]
    tau = np.zeros(np.shape(q)[:-1] + (n,))
    rev = robot.is_revolute
    for j in range(n):
        if not rev[j]:
            continue
        z = zs[..., j + shift, :]
        o = origins[..., j + shift, :]
        # every link from j on moves with joint j
        load = np.cross(tip - o, config.tool_mass * g)
        for k in range(j, n):
            load = load + np.cross(centres[..., k, :] - o, masses[k] * g)
        tau[..., j] = np.sum(z * load, axis=-1)
    return compliance * tau


class ServoBank:
    """Discretised second-order servo models of all joints, stepped together.

    Parameters
    ----------
    robot : Robot
    config : PhysicsConfig
    q0 : array_like, shape (n,), optional
        Initial shaft positions [rad] (default zeros, clipped to the limits).

    Examples
    --------
    >>> bank = ServoBank(Robot.load("arduino_arm_3dof"), PhysicsConfig(deadband=0.0))
    >>> bank.command([0.5, 0.5, 0.5])
    >>> bank.advance(2.0)
    >>> np.allclose(bank.position, 0.5, atol=1e-3)
    True
    """

    def __init__(self, robot, config=PhysicsConfig(), q0=None):
        import control

        self.robot = robot
        self.config = config
        n = robot.n
        wn, z = config.natural_frequency, config.damping_ratio
        sys_c = control.tf([wn * wn], [1.0, 2.0 * z * wn, wn * wn])
        sys_d = control.sample_system(sys_c, config.dt, method="zoh")
        ss = control.tf2ss(sys_d)
        #: the discrete transfer function of one servo (for inspection / docs)
        self.transfer_function = sys_d
        self._A = [[float(v) for v in row] for row in np.asarray(ss.A)]
        self._B = [float(v) for v in np.asarray(ss.B).ravel()]
        self._C = [float(v) for v in np.asarray(ss.C).ravel()]
        self._D = float(np.asarray(ss.D).ravel()[0])
        self._dc = self._dc_state()
        if config.rate_limit is None:
            rl = [lk.max_velocity if math.isfinite(lk.max_velocity) else math.radians(300) for lk in robot.links]
        else:
            rl = [config.rate_limit] * n
        self._max_step = [r * config.dt for r in rl]
        q0 = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float).reshape(n)
        q0 = np.clip(q0, robot.joint_limits[:, 0], robot.joint_limits[:, 1])
        self.time = 0.0
        self.reset(q0)

    def _dc_state(self):
        # steady state x for unit input: x = (I - A)^-1 B
        A = np.asarray(self._A)
        B = np.asarray(self._B)
        return np.linalg.solve(np.eye(len(B)) - A, B)

    def reset(self, q):
        """Put every servo at rest at shaft positions ``q`` [rad].

        Parameters
        ----------
        q : array_like, shape (n,)
            Shaft positions [rad]; they also become the commands.
        """
        q = [float(v) for v in np.asarray(q, dtype=float).reshape(self.robot.n)]
        self._x = [[float(v) * qi for v in self._dc] for qi in q]
        self._ref = list(q)
        self._target = list(q)
        self._cmd = list(q)
        self._y = list(q)
        self._yprev = list(q)

    def command(self, q):
        """Set the commanded shaft positions [rad] (shape (n,)).

        A changed command closer than ``deadband`` to the shaft position is
        ignored (the servo holds where it is), as a hobby servo does.

        Parameters
        ----------
        q : array_like, shape (n,)
            Commanded shaft positions [rad].
        """
        new = [float(v) for v in np.asarray(q, dtype=float).reshape(self.robot.n)]
        db = self.config.deadband
        for j, c in enumerate(new):
            if c != self._cmd[j]:
                self._target[j] = c if abs(c - self._y[j]) > db else self._y[j]
        self._cmd = new

    @property
    def commanded(self):
        """Commanded shaft positions, shape (n,) [rad]."""
        return np.array(self._cmd)

    @property
    def position(self):
        """Shaft positions, shape (n,) [rad]."""
        return np.array(self._y)

    @property
    def velocity(self):
        """Shaft speeds (finite difference over the last step), shape (n,) [rad/s]."""
        return (np.array(self._y) - np.array(self._yprev)) / self.config.dt

    def settled(self, tol=math.radians(0.5), speed=math.radians(2.0)):
        """Whether every shaft is within ``tol`` of its command (deadband included) and slower than ``speed``.

        Parameters
        ----------
        tol : float
            Largest position error [rad], on top of the deadband.
        speed : float
            Largest shaft speed [rad/s].

        Returns
        -------
        bool
        """
        err = np.abs(self.position - self.commanded)
        return bool(np.all(err <= tol + self.config.deadband) and np.all(np.abs(self.velocity) <= speed))

    def step(self, steps=1):
        """Advance the model by ``steps`` steps of ``dt``.

        Parameters
        ----------
        steps : int
            Number of time steps of ``config.dt`` [s].
        """
        A, B, C, D = self._A, self._B, self._C, self._D
        n = self.robot.n
        for _ in range(int(steps)):
            for j in range(n):
                d = self._target[j] - self._ref[j]
                m = self._max_step[j]
                self._ref[j] += m if d > m else (-m if d < -m else d)
                u = self._ref[j]
                x = self._x[j]
                y = C[0] * x[0] + C[1] * x[1] + D * u
                self._x[j] = [A[0][0] * x[0] + A[0][1] * x[1] + B[0] * u, A[1][0] * x[0] + A[1][1] * x[1] + B[1] * u]
                self._yprev[j] = self._y[j]
                self._y[j] = y
        self.time += steps * self.config.dt

    def advance(self, duration):
        """Advance by ``duration`` seconds (rounded to whole steps) [s].

        Parameters
        ----------
        duration : float
            Time to simulate [s], rounded to a whole number of ``config.dt`` steps.
        """
        self.step(int(round(duration / self.config.dt)))

    def advance_to(self, t):
        """Advance to model time ``t`` [s] (no-op if already there).

        Parameters
        ----------
        t : float
            Model time to reach [s] (whole steps only: the model stops at or
            just before ``t``).
        """
        steps = int((t - self.time) / self.config.dt + 1e-9)
        if steps > 0:
            self.step(steps)


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
        self._noise = _Noise(fb_rng, ruler_rng)
        self._servo_cal = [lk.servo for lk in robot.links]

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
        """Feedback ADC counts of every joint with a servo, shape (n,) (int, 0..1023; -1 where no servo).

        Each call draws fresh feedback noise.

        Returns
        -------
        ndarray of int, shape (n,)
            Counts 0..1023 (rounded, clipped), -1 for joints without a servo.
        """
        out = np.full(self.robot.n, -1, dtype=int)
        q = self.shaft_q
        for j, cal in enumerate(self._servo_cal):
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
        """Joint values sensed through the feedback ADC, shape (n,) [rad] (NaN where no servo).

        Returns
        -------
        ndarray, shape (n,)
            Sensed joint values [rad] (noisy, quantised).
        """
        adc = self.feedback_adc()
        return np.array(
            [float(cal.joint_from_adc(adc[j])) if cal is not None else math.nan for j, cal in enumerate(self._servo_cal)]
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
    """Physics for the firmware-in-the-loop harness (:mod:`labkit.firmware_sim`).

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
