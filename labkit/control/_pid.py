"""Joint models and PID design with python-control: margins, step information, root locus.

A joint's plant is either

* **identified**: the transfer function of a :class:`StepFit` (set-point to position of a servo
  whose own loop is closed), or
* **from the dynamics** (:func:`joint_plant`): torque to angle of joint ``j`` at a pose with the
  others held, ``G(s) = 1 / (m s^2 + b s + k)``: ``m = M(q)[j, j]`` the link inertia the joint sees
  plus the motor's reflected rotor inertia (:func:`labkit.dynamics.mass_matrix`), ``b = G^2 B`` the
  motor's viscous friction reflected through the gear, ``k = d g_j / d q_j`` gravity linearised at
  the pose (a central difference of :func:`labkit.dynamics.gravity_torques`; negative where gravity
  pulls the joint away, as for an arm held out).

:func:`design_pid` closes a unity-feedback loop with ``C(s) = kp + ki / s + kd s / (tf s + 1)``
and reports what python-control computes of it: :func:`control.stability_margins`,
:func:`control.step_info` of the closed loop, and the closed-loop poles for a range of loop gains
(root locus data, :func:`control.root_locus_map`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.exceptions import OptionError

__all__ = ["joint_plant", "PIDDesign", "design_pid"]


def joint_plant(robot, q, joint, *, gravity=None):
    """Torque-to-angle transfer function of one joint at a pose, the others held (module notes).

    Parameters
    ----------
    robot : Robot
        With inertial parameters (and, optionally, motors).
    q : array_like, shape (n,)
        The pose [rad, m].
    joint : int
        Joint index.
    gravity : array_like, shape (3,), optional
        Gravity [m/s^2] (default: the robot's).

    Returns
    -------
    control.TransferFunction
        ``1 / (m s^2 + b s + k)`` [rad / (N m)].

    Raises
    ------
    OptionError
        ``joint`` not an index 0..n-1.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> G = joint_plant(Robot.load("puma560"), [0, 0.5, 0, 0, 0, 0], 1)
    >>> G.den[0][0].size   # a second-order plant
    3
    """
    import control

    from labkit.dynamics import gravity_torques, mass_matrix
    from labkit.validation import as_vector, check_robot

    check_robot(robot)
    if isinstance(joint, bool) or not isinstance(joint, (int, np.integer)) or not 0 <= joint < robot.n:
        raise OptionError(f"expected a joint index 0..{robot.n - 1}, got {joint!r}")
    q = as_vector(q, robot.n, "q (the pose, rad)")
    m = float(mass_matrix(robot, q)[joint, joint])
    motor = robot.links[joint].motor
    b = 0.0 if motor is None else float(motor.gear_ratio) ** 2 * float(motor.viscous)
    h = 1e-6
    dq = np.zeros(robot.n)
    dq[joint] = h
    k = float(gravity_torques(robot, q + dq, gravity=gravity)[joint]
              - gravity_torques(robot, q - dq, gravity=gravity)[joint]) / (2 * h)
    return control.tf([1.0], [m, b, k])


@dataclass(frozen=True)
class PIDDesign:
    """A PID loop around a plant and what python-control says of it (:func:`design_pid`).

    Attributes
    ----------
    kp, ki, kd : float
        Gains (units of the plant's input per rad, per rad s, per rad/s).
    derivative_filter : float
        Time constant ``tf`` of the derivative's low-pass [s].
    plant, controller, loop, closed_loop : control.TransferFunction
        ``G``, ``C``, ``L = C G`` and ``T = L / (1 + L)``.
    gain_margin : float
        [1] (``inf`` when the phase never crosses -180 deg).
    phase_margin : float
        [deg].
    crossover : float
        Gain-crossover frequency [rad/s] (``nan`` if ``|L|`` never crosses 1).
    stable : bool
        Every closed-loop pole in the open left half-plane.
    step_info : dict
        :func:`control.step_info` of ``T`` (``RiseTime`` [s], ``SettlingTime`` [s], ``Overshoot`` [%] ...);
        empty when the closed loop is unstable.
    """

    kp: float
    ki: float
    kd: float
    derivative_filter: float
    plant: object
    controller: object
    loop: object
    closed_loop: object
    gain_margin: float
    phase_margin: float
    crossover: float
    stable: bool
    step_info: dict

    def step(self, t):
        """Closed-loop step response at times ``t`` [s] (:func:`control.step_response`).

        Parameters
        ----------
        t : array_like, shape (N,)
            Times [s] from the step, increasing from 0.

        Returns
        -------
        y : ndarray, shape (N,)
        """
        import control

        return np.asarray(control.step_response(self.closed_loop, T=np.asarray(t, dtype=float)).outputs).reshape(-1)

    def root_locus(self, gains=None):
        """Closed-loop poles of ``1 + K L(s) = 0`` for loop-gain factors ``K`` (root locus data).

        Parameters
        ----------
        gains : array_like, shape (k,), optional
            Factors ``K`` of the loop gain (default: 0.01 .. 100, log-spaced; ``K = 1`` is this design).

        Returns
        -------
        gains : ndarray, shape (k,)
        poles : ndarray, shape (k, p), complex
            The closed-loop poles [rad/s] for each factor.
        """
        import control

        gains = np.geomspace(0.01, 100.0, 81) if gains is None else np.asarray(gains, dtype=float)
        data = control.root_locus_map(self.loop, gains)
        return np.asarray(data.gains), np.asarray(data.loci)

    def to_dataframe(self):
        """The design's numbers as a two-column table (quantity, value).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        rows = [("kp", self.kp), ("ki", self.ki), ("kd", self.kd), ("gain margin [1]", self.gain_margin),
                ("phase margin [deg]", self.phase_margin), ("crossover [rad/s]", self.crossover),
                ("stable", "yes" if self.stable else "no")]
        rows += [(f"{k} [{'%' if 'shoot' in k else 's' if 'Time' in k else '1'}]", v)
                 for k, v in self.step_info.items() if k in ("RiseTime", "SettlingTime", "Overshoot")]
        return pd.DataFrame(rows, columns=["quantity", "value"])


def design_pid(plant, kp, ki=0.0, kd=0.0, *, derivative_filter=None):
    """Close a PID loop around ``plant`` and compute its margins, step information and stability.

    Parameters
    ----------
    plant : control.TransferFunction or StepFit
        The joint model (:func:`joint_plant`, or an identified :class:`StepFit`, its dead time as a
        third-order Padé approximation).
    kp, ki, kd : float
        Proportional, integral [1/s] and derivative [s] gains, finite, >= 0, kp > 0.
    derivative_filter : float, optional
        Time constant of the derivative's low-pass [s], > 0; default ``kd / kp / 10`` (1 ms without ``kd``).

    Returns
    -------
    PIDDesign

    Raises
    ------
    OptionError
        A gain negative or not finite, ``kp`` zero, or ``derivative_filter`` not > 0.

    Examples
    --------
    >>> import control
    >>> design = design_pid(control.tf([1.0], [0.01, 0.1, 0.0]), kp=4.0, kd=0.4)
    >>> design.stable, round(design.phase_margin) > 45
    (True, True)
    """
    import control

    if hasattr(plant, "transfer_function"):
        plant = plant.transfer_function()
    if not isinstance(plant, control.LTI):
        raise OptionError(f"expected plant as a python-control system (control.tf, joint_plant) or a StepFit, "
                          f"got {plant!r}")
    for name, value in (("kp", kp), ("ki", ki), ("kd", kd)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                or not np.isfinite(value) or value < 0:
            raise OptionError(f"expected {name} a finite number >= 0, got {value!r}")
    if kp == 0:
        raise OptionError("expected kp > 0, got 0")
    tf_d = (kd / kp / 10.0 if kd > 0 else 1e-3) if derivative_filter is None else derivative_filter
    if isinstance(tf_d, bool) or not (isinstance(tf_d, (int, float)) and np.isfinite(tf_d) and tf_d > 0):
        raise OptionError(f"expected derivative_filter > 0 s, got {derivative_filter!r}")
    s = control.tf("s")
    C = control.tf([float(kp)], [1.0])
    if ki > 0:
        C = C + ki / s
    if kd > 0:
        C = C + kd * s / (tf_d * s + 1)
    L = control.minreal(C * plant, verbose=False)
    T = control.feedback(L, 1)
    gm, pm, _, wc = control.margin(L)
    stable = bool(np.all(np.real(control.poles(T)) < 0))
    info = dict(control.step_info(T)) if stable else {}
    return PIDDesign(float(kp), float(ki), float(kd), float(tf_d), plant, C, L, T, float(gm), float(pm),
                     float(wc), stable, info)
