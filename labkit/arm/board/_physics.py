"""Physics of the virtual arm: servo dynamics, gravity sag, offsets, noise, a ruler.

One model serves both simulated boards: the pure-Python virtual arm
(:mod:`labkit.arm`) and the firmware-in-the-loop harness
(:mod:`labkit.arm`, through :class:`FirmwareAdapter`, which only
supplies pulse widths and takes analog feedback voltages back).

Model, per joint ``j`` (see ``docs/virtual-arm.md``):

* the commanded joint value passes a **deadband** (the servo ignores a new
  command closer than ``deadband`` to where the shaft already is) and a
  **rate limit** (the reference moves at most ``rate_limit`` [rad/s]), then a
  **second-order transfer function** ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``
  built with :func:`control.tf` and discretised with
  :func:`control.sample_system` (zero-order hold, step ``dt``);
* an **RC linear servo** (a prismatic joint's servo table, e.g. an Actuonix L16-R) is the same loop in
  metres: its reference moves at most at the servo's datasheet speed (the table's ``no_load_speed``, else the
  joint's ``max_velocity``, else 0.1 m/s), its deadband is ``linear_deadband`` and it has no zero offset
  (no horn to mount one spline off); gravity does not bend a prismatic joint;
* a joint **without a servo** (no ``servo`` or ``[bus]`` table) is an ideal actuator
  (:mod:`labkit.arm`'s ``_actuator``): it follows its command within the joint limits at the
  joint's ``max_velocity`` and ``max_acceleration`` (defaults 90 deg/s and 360 deg/s^2, 0.1 m/s
  and 0.5 m/s^2), without lag or deadband, and an encoder over its limits reports it;
* the shaft position read by the servo's potentiometer is the model output;
  the **true joint** adds a per-joint **zero-offset** error (horn mounted one
  spline off, seeded) and the **gravity sag** of the links (joint compliance
  times the gravity torque, quasi-static; the pot does not see it); an ideal
  actuator holds its joint where it is sent: it does not yield (a hobby servo's
  0.04 rad/(N m) under a 12 kg industrial link would be a sag of radians);
* the **feedback** is the pot voltage as 10-bit ADC counts with Gaussian noise;
* the **ruler** returns the true end-effector position with reading noise,
  rounded to the ruler's resolution (seed 000: 0.5 mm).

Everything random is drawn from generators seeded by :attr:`PhysicsConfig.seed`
(independent streams for offsets, feedback noise and the ruler).

Coordinates: the base frame of the robot file. Gravity points along ``-up``
(the robot file's ``up``, :attr:`labkit.robot.Robot.up`) unless
:attr:`PhysicsConfig.gravity` sets it: ``+z`` for the seed 000 arm, whose base z
axis points **down** (``up = -z0``: its IK negates the user's Z; its shoulder
sweeps over the top through q2 = 90 deg at z = -0.274 m), ``-z`` for a PUMA
standing on its base. Calibration (:func:`labkit.measure.calibrate`) fits the
sag along the same ``-up``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.robot import Convention, JointType
from labkit.arm._actuator import IDEAL_VELOCITY, ideal_speed_limits, is_ideal

__all__ = ["PhysicsConfig", "ServoBank", "gravity_sag", "point_mass_links", "ADC_VREF", "ADC_MAX"]

#: reference voltage and full scale of the board's 10-bit ADC (Arduino Uno)
ADC_VREF = 5.0
#: an ideal actuator's command that changes again within this time [s] is a moving reference (a streamed
#: trajectory changes it every 20 ms servo frame); one changed after a longer pause is a new goal to stop at
RATE_WINDOW = 0.1
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
        Largest reference speed [rad/s | m/s]; ``None`` uses each servo's datasheet ``no_load_speed``, else the link's
        ``max_velocity``, else 5.24 rad/s = 300 deg/s (a linear servo: 0.1 m/s).
    deadband : float
        Servo deadband [rad] (about 5 us of pulse on a hobby servo).
    linear_deadband : float
        Deadband of an RC linear servo [m] (0.25 mm: the L16's datasheet backlash, 5 us of its pulse over 50 mm).
    zero_offset_std : float
        Standard deviation of the random per-joint zero-offset errors [rad].
    zero_offsets : tuple of float or None
        Explicit zero-offset errors per joint [rad] (overrides the random ones).
    joint_compliance : float or tuple of float
        Joint compliance [rad/(N m)] (scalar or per joint) of the servos; an ideal actuator (a joint
        without a servo) does not yield.
    link_masses : tuple of float or None
        Mass of each moving link [kg], a point at the middle of the link
        (:func:`point_mass_links`); ``None``: the
        robot file's inertias (``mass``, ``com``, ``inertia``) through
        :func:`labkit.dynamics.gravity_torques` where it has them, else 0.05 kg each.
    tool_mass : float
        Mass at the tool point (gripper with its servo) [kg].
    gravity : tuple of float or None
        Gravity in the robot's base frame [m/s^2]; ``None`` (default): 9.81 along
        the robot's ``-up`` (see module notes).
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
    linear_deadband: float = 0.25e-3
    zero_offset_std: float = math.radians(1.0)
    zero_offsets: tuple | None = None
    joint_compliance: float | tuple = 0.04
    link_masses: tuple | None = None
    tool_mass: float = 0.08
    gravity: tuple | None = None
    feedback_noise: float = 1.0
    ruler_resolution: float = 0.5e-3
    ruler_noise: float = 0.3e-3

    def __post_init__(self):
        for name in ("dt", "natural_frequency", "damping_ratio"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise OptionError(f"expected {name} > 0, got {v!r}")
        for name in ("deadband", "linear_deadband", "zero_offset_std", "tool_mass", "feedback_noise", "ruler_resolution", "ruler_noise"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise OptionError(f"expected {name} >= 0, got {v!r}")
        if self.rate_limit is not None and not self.rate_limit > 0:
            raise OptionError(f"expected rate_limit > 0 or None, got {self.rate_limit!r}")
        if self.gravity is not None and (len(self.gravity) != 3 or not np.all(np.isfinite(self.gravity))):
            raise ShapeError(f"expected gravity with 3 finite components or None, got {self.gravity!r}")

    def streams(self):
        """Independent generators ``(offsets, feedback, ruler)`` for this seed.

        Returns
        -------
        tuple of numpy.random.Generator
            Three generators spawned from ``SeedSequence(seed)``: the same
            numbers on every call with the same seed.
        """
        return tuple(np.random.default_rng(s) for s in np.random.SeedSequence(self.seed).spawn(3))


def _servo_speed(link):
    """A servo's largest speed [rad/s | m/s]: its datasheet ``no_load_speed``, else the joint's ``max_velocity``, else a default
    (300 deg/s for a hobby servo, an ideal linear actuator's 0.1 m/s for a linear servo)."""
    if link.servo is not None and link.servo.no_load_speed is not None:
        return link.servo.no_load_speed
    if link.max_velocity is not None:
        return link.max_velocity
    return math.radians(300) if link.joint_type is JointType.REVOLUTE else IDEAL_VELOCITY[False]


def _per_joint(value, n, name):
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 else np.asarray(value, float)
    if arr.shape != (n,):
        raise ShapeError(f"expected {name} as a scalar or {n} values, got shape {arr.shape}")
    return arr.copy()


def point_mass_links(robot, masses):
    """``robot`` with each link's mass as a point at the middle of the link (the inertias of a file that has none).

    Link ``j`` runs from the origin of the frame that carries joint ``j``'s axis (frame ``j - 1``
    in the standard DH convention, frame ``j`` in the modified one) to that of joint ``j + 1``
    (the tool point for the last link): a segment fixed in the frame that moves with joint ``j``
    (where joint ``j + 1`` slides, at the middle of its limits).

    Parameters
    ----------
    robot : Robot
    masses : array_like, shape (n,)
        Mass of each moving link [kg].

    Returns
    -------
    Robot
        A copy whose links carry :class:`labkit.robot.LinkInertia` point masses (no rotational
        inertia), for :func:`labkit.dynamics.gravity_torques`.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = point_mass_links(Robot.load("planar3r_seed003"), [0.05, 0.05, 0.05])
    >>> [round(c * 1000, 1) for c in arm.links[0].inertial.com]   # the middle of the 145 mm first link [mm]
    [72.5, 0.0, 0.0]
    """
    from labkit.kinematics import fk_frames
    from labkit.robot import LinkInertia

    n = robot.n
    masses = _per_joint(masses, n, "link_masses")
    T = fk_frames(robot, robot.joint_limits.mean(axis=1))  # (n + 2, 4, 4): base, frames 1..n, tool
    axis = [j + (1 if robot.convention is Convention.MODIFIED else 0) for j in range(n)] + [n + 1]
    for j in range(n):
        middle = 0.5 * (T[axis[j], :3, 3] + T[axis[j + 1], :3, 3])
        com = np.linalg.solve(T[j + 1], np.append(middle, 1.0))[:3]  # in frame j + 1, the one joint j moves
        robot = robot.with_link(j, inertial=LinkInertia(float(masses[j]), tuple(float(c) for c in com)))
    return robot


def gravity_sag(robot, q, config=PhysicsConfig()):
    """Quasi-static joint deflection under gravity.

    The deflection of joint ``j`` is its compliance times the gravity torque about its axis,
    :func:`labkit.dynamics.gravity_torques` of the robot file's inertias with ``tool_mass`` as a
    payload at the tool point; without inertias (or with ``link_masses`` given) each link's mass
    is a point at the middle of the link (:func:`point_mass_links`). A joint whose file names a
    geared ``motor`` (ratio ``G``) has ``joint_compliance / G**2`` (the drive's loop holds the
    motor shaft); an ideal actuator (a joint without a servo or bus table) does not yield.

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
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> dq = gravity_sag(arm, [0.0, 0.0, 0.0])   # arm horizontal: the shoulder yields most
    >>> np.round(np.degrees(dq), 2)
    array([ 0.  , -0.75,  0.42])
    """
    from labkit.dynamics import gravity_torques

    n = robot.n
    compliance = _per_joint(config.joint_compliance, n, "joint_compliance")
    g = -9.81 * np.asarray(robot.up, dtype=float) if config.gravity is None else np.asarray(config.gravity, dtype=float)
    if config.link_masses is not None or all(lk.inertial is None for lk in robot.links):
        robot = point_mass_links(robot, 0.05 if config.link_masses is None else config.link_masses)
    held = robot.with_payload(config.tool_mass) if config.tool_mass > 0 else robot
    # a drive with a gearbox (the file's motor.gear_ratio G) holds its position loop at the motor: the
    # joint sees that compliance divided by G^2 (a hobby servo's compliance is already at its horn)
    gears = np.array([1.0 if lk.motor is None else float(lk.motor.gear_ratio) for lk in robot.links])
    compliance = compliance / gears**2 * [not is_ideal(lk) for lk in robot.links]
    return 0.0 - compliance * gravity_torques(held, q, gravity=g) * robot.is_revolute  # 0.0 -: no -0


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
    >>> from labkit.robot import Robot
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
            rl = [_servo_speed(lk) for lk in robot.links]
        else:
            rl = [config.rate_limit] * n
        linear = [lk.joint_type is JointType.PRISMATIC for lk in robot.links]
        #: each servo's deadband [rad | m]: a hobby servo's, an RC linear servo's
        self._deadband = [config.linear_deadband if lin else config.deadband for lin in linear]
        # joints without a servo are ideal actuators (labkit.arm): they follow a reference limited in speed and
        # acceleration exactly (no servo lag, no deadband)
        self._ideal = [is_ideal(lk) for lk in robot.links]
        limits = [ideal_speed_limits(robot, j) if self._ideal[j] else (rl[j], math.inf) for j in range(n)]
        if config.rate_limit is not None:
            limits = [(config.rate_limit, a) for _, a in limits]
        self._max_step = [v * config.dt for v, _ in limits]
        self._max_dv = [a * config.dt for _, a in limits]
        self._v = [0.0] * n
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
        self._v = [0.0] * len(q)
        # an ideal actuator's reference rate [rad/s | m/s]: a command that keeps moving (a streamed trajectory, a
        # new value every servo frame) is followed at its own speed, a held one braked on (see _step_ideal)
        self._rate = [0.0] * len(q)
        self._t_cmd = [-math.inf] * len(q)  # when each command last changed [s]
        self._gap = [math.inf] * len(q)  # the time between its last two changes [s]

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
        for j, c in enumerate(new):
            if c != self._cmd[j]:
                self._target[j] = c if self._ideal[j] or abs(c - self._y[j]) > self._deadband[j] else self._y[j]
                gap = self.time - self._t_cmd[j]
                # the rate of a command that changed twice within RATE_WINDOW (a one-off jump: rate 0)
                self._rate[j] = (c - self._cmd[j]) / gap if 0.0 < gap <= RATE_WINDOW else 0.0
                self._t_cmd[j], self._gap[j] = self.time, gap
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
        return bool(np.all(err <= tol + np.array(self._deadband)) and np.all(np.abs(self.velocity) <= speed))

    def step(self, steps=1):
        """Advance the model by ``steps`` steps of ``dt``.

        Parameters
        ----------
        steps : int
            Number of time steps of ``config.dt`` [s].
        """
        A, B, C, D = self._A, self._B, self._C, self._D
        n = self.robot.n
        for k in range(int(steps)):
            for j in range(n):
                if self._ideal[j]:
                    self._step_ideal(j, self.time + (k + 1) * self.config.dt)
                    continue
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

    def _step_ideal(self, j, t):
        """One step of an ideal actuator: the speed that still stops at the target, reached within the acceleration.

        A moving command (changed again within 1.5 of its last gap) is extrapolated at its rate and its rate fed
        forward, so a streamed plan within the speed limits is followed without lag, not braked on at every frame."""
        dt, dv = self.config.dt, self._max_dv[j]
        since = t - dt - self._t_cmd[j]  # from the command's change to this step's start
        rate = self._rate[j] if self._rate[j] and since + dt <= 1.5 * self._gap[j] else 0.0
        e = self._target[j] + (rate * since if rate else 0.0) - self._y[j]  # behind the moving command
        # the largest step from which steps shrinking by a dt^2 at every step end on the target (a discrete
        # braking curve: s + (s - k) + (s - 2k) + ... = |d| with k = a dt^2), capped by the speed and the distance
        k = dv * dt
        brake = k * (math.sqrt(0.25 + 2.0 * abs(e) / k) - 0.5) if math.isfinite(k) and k > 0 else math.inf
        v_goal = rate + math.copysign(min(self._max_step[j], brake, abs(e)), e) / dt
        v_goal = max(-self._max_step[j] / dt, min(self._max_step[j] / dt, v_goal))
        v = self._v[j]
        v = v + max(-dv, min(dv, v_goal - v))
        step = v * dt
        d = e + rate * dt  # to where the command is at the step's end
        if abs(d - step) < 1e-12:
            step, v = d, 0.0 if abs(d) < 1e-12 else v
        self._v[j] = v
        self._yprev[j] = self._y[j]
        self._y[j] += step
        self._ref[j] = self._y[j]

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
