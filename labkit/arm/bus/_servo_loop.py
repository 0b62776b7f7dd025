"""A smart servo's own position loop on the arm's dynamics: what a virtual bus's servos run, and its linear model.

A Dynamixel XM430 or a Feetech STS3215 closes its position loop inside the servo: every control
period ``Ts`` it compares the goal with its encoder, computes a PID output and drives its motor
with it. The virtual bus (:class:`labkit.arm.bus.BusEmulator`) runs that loop on the joint's
dynamics, so that a gain written to the servo changes the response the way it does on the real
one. The model of joint ``j`` (independent-joint control: the other joints' motion is not fed back
into this one):

* the loop, in the servo's own units (the bus module's ``GAINS``: register value times the
  factor the vendor states)::

      e = goal - present [ticks],  out = kp e + ki sum(e) + kd (e - e_prev)  [output LSB per period Ts]
      u = clip(out / full_scale, -1, 1)

* the motor (a DC motor at its supply voltage, ``u`` its duty cycle), through its gearbox to the
  joint::

      tau = stall_torque * u - (stall_torque / no_load_speed) * qd

* the joint: ``J qdd = tau + tau_load``, with ``J`` the reflected rotor inertia
  ``gear_ratio**2 * rotor_inertia`` plus the link inertia the joint sees at the present pose (the
  diagonal of :func:`labkit.dynamics.mass_matrix` with the virtual arm's tool mass), and
  ``tau_load`` the gravity torque at that pose (:func:`labkit.arm.board.gravity_sag` with unit
  compliance), both updated every physics step ``dt``.

Linearised (no saturation, ``Ts`` small), the loop is the second-order system of
:func:`position_loop`: ``J s^2 + (b + Kd) s + Kp`` with ``Kp = stall_torque / full_scale * kp *
ticks_per_rad``, ``Kd = stall_torque / full_scale * kd * ticks_per_rad * Ts`` and ``b`` the motor's
back-EMF damping ``stall_torque / no_load_speed`` (and ``Ki`` likewise). Its steady error under a
load ``tau_load`` is ``tau_load / Kp`` when ``ki = 0``: a servo with its factory gains droops.

Assumed (not published by the vendors): the control period ``Ts`` = 1 ms, the rotor inertias
(the bus module's ``MOTOR["rotor_inertia"]``), and for Feetech the factor 1 between the coefficients and the output
(Feetech documents no conversion). Gearbox friction and backlash are not modelled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from labkit.arm.board import gravity_sag

__all__ = ["CONTROL_PERIOD", "LoopPlant", "loop_plant", "position_loop", "PositionLoops"]

#: the servo's control period [s] (assumed: neither vendor publishes it)
CONTROL_PERIOD = 1e-3


@dataclass(frozen=True)
class LoopPlant:
    """One joint's servo and the inertia it drives (see the module notes).

    Attributes
    ----------
    inertia : float
        ``J`` [kg m^2]: reflected rotor plus link inertia at the pose.
    damping : float
        ``b`` = stall torque / no-load speed [N m s/rad] (the motor's back-EMF).
    torque_per_tick : float
        Torque of one output LSB per tick of error [N m / tick]: ``stall_torque / full_scale`` times the gain.
    ticks_per_rad : float
        Encoder ticks per radian.
    factors : dict
        ``kp``, ``ki``, ``kd`` -> factor from the register value to the loop's gain (the bus module's ``GAINS``).
    """

    inertia: float
    damping: float
    torque_per_tick: float
    ticks_per_rad: float
    factors: dict

    def stiffness(self, gains):
        """``Kp``, ``Ki``, ``Kd`` of the loop in SI: [N m/rad], [N m/(rad s)], [N m s/rad].

        Parameters
        ----------
        gains : mapping
            ``kp``, ``ki``, ``kd`` register values.

        Returns
        -------
        tuple of float
        """
        base = self.torque_per_tick * self.ticks_per_rad
        kp = base * self.factors["kp"] * gains["kp"]
        ki = base * self.factors["ki"] * gains["ki"] / CONTROL_PERIOD
        kd = base * self.factors["kd"] * gains["kd"] * CONTROL_PERIOD
        return kp, ki, kd


#: the pose change [rad] after which a joint's inertia and gravity load are computed again (both vary slowly)
RELOAD = 0.03


def _pose_loads(robot, q, config, held=None):
    """Link inertia each joint sees [kg m^2] and the gravity torque on it [N m] at ``q`` (virtual arm's masses)."""
    from labkit.dynamics import mass_matrix

    if held is None:
        held = robot.with_payload(config.tool_mass) if config.tool_mass > 0 else robot
    try:
        inertia = np.diagonal(mass_matrix(held, q)).copy()
    except ValueError:  # no inertial data at all (no tool mass either): the rotor alone
        inertia = np.zeros(robot.n)
    return inertia, gravity_sag(robot, q, replace(config, joint_compliance=1.0))


def loop_plant(robot, joint, bus, q, config):
    """The :class:`LoopPlant` of ``robot``'s joint ``joint`` on bus module ``bus`` at pose ``q``.

    Parameters
    ----------
    robot : Robot
    joint : int
        Joint index.
    bus : module
        The bus's codec module (``MOTOR``, ``GAINS``, ``PROTOCOL``).
    q : array_like, shape (n,)
        Pose [rad].
    config : PhysicsConfig
        The virtual arm's masses (``tool_mass``, ``link_masses``).

    Returns
    -------
    LoopPlant
    """
    inertia, _ = _pose_loads(robot, np.asarray(q, float), config)
    return _plant(robot, joint, bus, inertia[joint])


def _plant(robot, joint, bus, link_inertia):
    motor = bus.MOTOR
    rotor = motor["gear_ratio"] ** 2 * motor["rotor_inertia"]
    return LoopPlant(inertia=float(rotor + link_inertia), damping=motor["stall_torque"] / motor["no_load_speed"],
                     torque_per_tick=motor["stall_torque"] / motor["full_scale"],
                     ticks_per_rad=robot.links[joint].bus.resolution / (2 * math.pi),
                     factors={k: v[2] for k, v in bus.GAINS.items()})


def position_loop(plant, gains):
    """The linearised closed position loop, goal -> present position, as a python-control transfer function.

    ``(Kd s^2 + Kp s + Ki) / (J s^3 + (b + Kd) s^2 + Kp s + Ki)`` (``Kd`` acts on the error, as in the
    servo's loop; see the module notes); with ``ki = 0`` the common root ``s = 0`` is cancelled:
    ``(Kd s + Kp) / (J s^2 + (b + Kd) s + Kp)``.

    Parameters
    ----------
    plant : LoopPlant
    gains : mapping
        ``kp``, ``ki``, ``kd`` register values.

    Returns
    -------
    control.TransferFunction

    Examples
    --------
    >>> from labkit.arm.bus import bus_module
    >>> plant = LoopPlant(0.0125, 0.85, 4.1 / 885, 651.9, {k: v[2] for k, v in bus_module("dynamixel").GAINS.items()})
    >>> import control
    >>> [round(control.step_info(position_loop(plant, {"kp": kp, "ki": 0, "kd": 0}))["Overshoot"]) for kp in (800, 3200)]
    [0, 22]
    """
    import control

    kp, ki, kd = plant.stiffness(gains)
    if ki == 0:
        return control.tf([kd, kp], [plant.inertia, plant.damping + kd, kp])
    return control.tf([kd, kp, ki], [plant.inertia, plant.damping + kd, kp, ki])


class PositionLoops:
    """Every joint's servo running its position loop on the dynamics (the virtual bus's :attr:`ArmModel.servos`).

    The interface of :class:`labkit.arm.board.ServoBank` (``command``, ``commanded``, ``position``,
    ``velocity``, ``settled``, ``step``, ``advance``, ``advance_to``, ``time``), with the gains of
    each servo settable (:meth:`set_gains`).

    Parameters
    ----------
    robot : Robot
    config : PhysicsConfig
        Physics step ``dt`` and the virtual arm's masses.
    bus : module
        The bus's codec module.
    q0 : array_like, shape (n,)
        Where the shafts rest [rad].
    gravity : bool
        Whether the loops carry the gravity load (see :attr:`gravity`).

    Attributes
    ----------
    gravity : bool
        ``True``: each loop carries its joint's gravity torque, so a servo without integral gain droops by
        ``tau_load / Kp`` as a real one does; ``False``: the loops drive the inertia alone (the gravity load
        still shows in the virtual bus's present current).
    """

    def __init__(self, robot, config, bus, q0, *, gravity=False):
        self.robot = robot
        self.gravity = bool(gravity)
        self.config = config
        self.bus = bus
        n = robot.n
        self.gains = [dict(bus.DEFAULT_GAINS) for _ in range(n)]
        self.time = 0.0
        self._ticks = np.array([lk.bus.resolution / (2 * math.pi) for lk in robot.links])
        self._substeps = max(1, int(round(config.dt / CONTROL_PERIOD)))
        self._speed = [lk.max_velocity for lk in robot.links]
        q0 = np.clip(np.asarray(q0, float).reshape(n), robot.joint_limits[:, 0], robot.joint_limits[:, 1])
        self._q = q0.copy()
        self._qd = np.zeros(n)
        self._qprev = q0.copy()
        self._cmd = q0.copy()
        self._ref = q0.copy()
        self._sum = np.zeros(n)
        self._err = np.zeros(n)
        #: whether each servo's torque is on (a servo with torque off is held by its gearbox: it stays where it is)
        self.enabled = np.zeros(n, dtype=bool)
        self._rotor = _plant(robot, 0, bus, 0.0).inertia
        self._held = robot.with_payload(config.tool_mass) if config.tool_mass > 0 else robot
        self._loads_at = None
        self._loads = None
        self._pose()  # imports the dynamics now, not in the middle of a bus transaction

    def _pose(self):
        """Link inertia and gravity load at the present pose, computed again after a change of :data:`RELOAD`."""
        if self._loads_at is None or np.max(np.abs(self._q - self._loads_at)) > RELOAD:
            self._loads_at = self._q.copy()
            self._loads = _pose_loads(self.robot, self._q, self.config, self._held)
        return self._loads

    def reset(self, q):
        """Put every shaft at rest at ``q`` [rad] (shape (n,)), which also becomes the goal.

        Parameters
        ----------
        q : array_like, shape (n,)
        """
        q = np.asarray(q, float).reshape(self.robot.n)
        self._q, self._qd, self._cmd, self._ref = q.copy(), np.zeros(self.robot.n), q.copy(), q.copy()
        self._sum[:] = 0.0
        self._err[:] = 0.0

    def enable(self, joint, on):
        """Torque on (``True``) or off on joint ``joint``'s servo; turning it on restarts its loop at the present position.

        Parameters
        ----------
        joint : int
        on : bool
        """
        if on and not self.enabled[joint]:
            self._ref[joint] = self._q[joint]
            self._sum[joint] = 0.0
            self._err[joint] = 0.0
        self.enabled[joint] = bool(on)

    def set_gains(self, joint, gains):
        """New gains of joint ``joint``'s servo (register values; the loop's integral is kept).

        Parameters
        ----------
        joint : int
        gains : mapping
            ``kp``, ``ki``, ``kd`` (any subset).
        """
        self.gains[joint].update({k: int(v) for k, v in gains.items()})

    def command(self, q):
        """New goal positions [rad], shape (n,).

        Parameters
        ----------
        q : array_like, shape (n,)
        """
        self._cmd = np.asarray(q, float).reshape(self.robot.n).copy()

    @property
    def commanded(self):
        """Goal positions, shape (n,) [rad]."""
        return self._cmd.copy()

    @property
    def position(self):
        """Shaft positions, shape (n,) [rad]."""
        return self._q.copy()

    @property
    def velocity(self):
        """Shaft speeds, shape (n,) [rad/s]."""
        return self._qd.copy()

    def settled(self, tol=math.radians(0.5), speed=math.radians(2.0)):
        """Whether every shaft is within ``tol`` [rad] of its goal and slower than ``speed`` [rad/s].

        Parameters
        ----------
        tol : float
        speed : float

        Returns
        -------
        bool
        """
        return bool(np.all(np.abs(self._q - self._cmd) <= tol) and np.all(np.abs(self._qd) <= speed))

    def step(self, steps=1):
        """Advance ``steps`` physics steps of ``config.dt`` (each ``dt / Ts`` control periods).

        Parameters
        ----------
        steps : int
        """
        bus, cfg = self.bus, self.config
        full, b = bus.MOTOR["full_scale"], bus.MOTOR["stall_torque"] / bus.MOTOR["no_load_speed"]
        stall = bus.MOTOR["stall_torque"]
        factors = {k: v[2] for k, v in bus.GAINS.items()}
        kp = np.array([factors["kp"] * g["kp"] for g in self.gains])
        ki = np.array([factors["ki"] * g["ki"] for g in self.gains])
        kd = np.array([factors["kd"] * g["kd"] for g in self.gains])
        h = cfg.dt / self._substeps
        for _ in range(int(steps)):
            link, load = self._pose()
            load = load if self.gravity else 0.0
            inertia = self._rotor + link
            on = self.enabled
            for j, vmax in enumerate(self._speed):  # the profile: the goal approached at the joint's speed
                d = self._cmd[j] - self._ref[j]
                m = math.inf if vmax is None else vmax * cfg.dt
                self._ref[j] += min(max(d, -m), m)
            goal = np.round(self._ref * self._ticks)
            for _ in range(self._substeps):
                err = goal - np.round(self._q * self._ticks)
                self._sum += err
                out = kp * err + ki * self._sum + kd * (err - self._err)
                self._err = err
                u = np.clip(out / full, -1.0, 1.0)
                tau = stall * u - b * self._qd + load
                self._qd = np.where(on, self._qd + h * tau / inertia, 0.0)
                self._q = self._q + h * self._qd
            self.time += cfg.dt

    def advance(self, duration):
        """Advance by ``duration`` [s] (whole physics steps).

        Parameters
        ----------
        duration : float
        """
        self.step(int(round(duration / self.config.dt)))

    def advance_to(self, t):
        """Advance to time ``t`` [s] (no-op if already there).

        Parameters
        ----------
        t : float
        """
        steps = int((t - self.time) / self.config.dt + 1e-9)
        if steps > 0:
            self.step(steps)
