"""A lab for any arm: ``labkit new LAB_DIR --robot ROBOT_FILE``.

:func:`new_lab` copies the generic template notebooks shipped in
``labkit/labs/templates/`` into a lab folder, with the robot file next to them (byte for
byte: comments, ranges and all), and each notebook's ``parameters`` cell rewritten with defaults picked from the robot by
:func:`lab_defaults`: the joint window the servos can reach, a home pose, a measurement
plan, IK targets that the robot's solver reaches inside the limits, a joint move, and a
Cartesian line and arc that stay inside the window. The lab renders like the seed labs
(``labkit render LAB_DIR``) against the virtual arm (``sim://``); an arm on a Dynamixel or Feetech
servo bus (a robot file with a ``[bus]`` table) runs on its virtual bus
(``sim://robot.toml?bus=dynamixel``: the vendor SDK's packets to an emulated bus).

Parameters are in the units people read (degrees, millimetres; see
:func:`labkit.robot.joints_from_display` and :func:`labkit.kinematics.target_from_display`).

Example
-------
>>> from labkit.labs import lab_defaults
>>> d = lab_defaults("planar3r_seed003")
>>> d.description, d.target, round(d.reach, 3)
('planar 3-DOF', 'planar', 0.335)
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from labkit.exceptions import LabkitError, needs_extra
from labkit.kinematics import (
    REDUCED_KINDS as REDUCED, fk, ik_all, jacobian, target_error, target_from_pose, target_kind, target_to_display,
)
from labkit.robot import Robot, ServoCalibration, joints_from_display, joints_to_display, robot_reach, servo_window

__all__ = ["TEMPLATE_DIR", "LabDefaults", "NewLab", "lab_defaults", "with_servos", "template_values", "new_lab"]

#: the generic lab notebooks shipped with the package
TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"
#: the robot file's name inside a lab folder (the user's file, copied unchanged)
ROBOT_FILE = "robot.toml"
_PARAM_DOC = {
    "robot": "robot file (or bundled robot name)",
    "port": "the virtual arm; a real board: \"/dev/ttyACM0\" (COM3 on Windows)",
    "home": "joint values [deg | mm]",
    "poses": "measurement plan / FK poses, one row per pose [deg | mm]",
    "targets": "IK targets: x, y, z [mm] (planar: x, y [mm], phi [deg]; 4-DOF: + pitch [deg]; 5-DOF: + pitch, "
               "roll [deg]; 6-DOF: + roll, pitch, yaw [deg])",
    "move": "joint move: start and end rows [deg | mm]",
    "line_mm": "Cartesian line: start and end points [mm]",
    "arc": "Cartesian arc: centre [mm], radius [mm], start angle and sweep [deg] about +z (or about \"normal\", a 4-DOF arm's vertical plane)",
    "duration": "duration of each move [s]",
    "readings": "readings per pose and quantity",
    "payload_kg": "mass at the tool [kg]: the gripper and what it holds (the virtual arm's gripper: 0.08 kg; weigh yours)",
    "measurements": "measurement log (CSV) to use; \"\" = measure on `port` now (into output_dir)",
    "output_dir": "where the notebook writes files",
}
#: mass at the tool the lab notebooks assume [kg]: the virtual arm's gripper (labkit.arm.PhysicsConfig.tool_mass)
PAYLOAD_KG = 0.08
_ONE_CURVE = "a 1-DOF arm's tool moves on one curve (a circle about its joint or a line along it): no Cartesian path to plan"
#: templates only some robots get: (stem, what the robot needs, why a lab without it leaves the notebook out)
_NEEDS = (
    ("04_trajectory", lambda robot: robot.n > 1, _ONE_CURVE),
    ("07_dynamics", lambda robot: any(lk.inertial is not None for lk in robot.links),
     "the robot file has no inertias (mass, com, inertia per joint; docs/robot-files.md)"),
    ("08_control", lambda robot: robot.n > 1, _ONE_CURVE + " (its last part tracks a line)"),
    ("08_control", lambda robot: all(lk.servo is not None or lk.bus is not None for lk in robot.links)
     or all(lk.inertial is not None for lk in robot.links),
     "joints without a servo are ideal actuators (no servo dynamics to identify) and not every link has an inertia"),
)


@dataclass(frozen=True)
class LabDefaults:
    """Defaults of a lab, picked from a robot (display units: deg, mm).

    Attributes
    ----------
    description : str
        ``"spatial 3-DOF"``, ``"planar 3-DOF"``, ``"4-DOF"``, ``"6-DOF pose"``, ... with
        ``", prismatic"`` when a joint slides.
    target : str
        IK target kind (:func:`labkit.kinematics.target_kind`): ``"position"``, ``"planar"``,
        ``"position_pitch"``, ``"position_pitch_roll"`` or ``"pose"``.
    reach : float
        Sum of the link lengths and offsets [m].
    parameters : dict
        Parameter name -> value (lists of numbers in deg / mm) for the templates.
    """

    description: str
    target: str
    reach: float
    parameters: dict = field(default_factory=dict)


@dataclass(frozen=True)
class NewLab:
    """A lab folder made by :func:`new_lab`.

    Attributes
    ----------
    folder : Path
    robot_file : Path
        The user's robot file, copied unchanged (``robot.toml``).
    notebooks : tuple of Path
    description : str
        :attr:`LabDefaults.description`.
    lab_robot_file : Path
        The robot file the notebooks use (``robot_file``).
    notes : tuple of str
        Which joints run as ideal actuators on the virtual arm and their ranges, and the notebooks the
        lab left out and why (printed by ``labkit new``); empty when nothing needs saying.
    """

    folder: Path
    robot_file: Path
    notebooks: tuple
    description: str
    lab_robot_file: Path = None
    notes: tuple = ()


def with_servos(robot):
    """``robot`` with a hobby-servo calibration on every joint that has none (channel = joint index).

    For a course that drives its joints with hobby servos; ``labkit new`` does not call it (a joint
    without a servo is an ideal actuator on the virtual arm).

    A revolute joint's 180-deg servo travel is centred on the middle of its limits (the whole
    limits when they span at most 180 deg); a prismatic joint reads its length as the servo
    "angle" from 0 (the wire format of ``labkit.arm``). A robot on a servo bus (a ``[bus]``
    table: every joint is a bus servo) is returned unchanged: its servos are the bus's.

    Parameters
    ----------
    robot : Robot or str
        Robot or robot file.

    Returns
    -------
    Robot
        A copy with a :class:`labkit.robot.ServoCalibration` on every joint (``robot`` itself
        on a servo bus).
    """
    robot = Robot.load(robot)
    if robot.bus is not None:
        return robot
    for j, lk in enumerate(robot.links):
        if lk.servo is not None:
            continue
        lo, hi = lk.limits
        if robot.is_revolute[j]:
            zero = -lo if hi - lo <= math.pi else math.pi / 2 - (lo + hi) / 2
        else:
            zero = max(0.0, -lo)
        robot = robot.with_link(j, servo=ServoCalibration(channel=j, zero=float(zero)))
    return robot


def _description(robot, target):
    n = robot.n
    label = {"planar": f"planar {n}-DOF", "pose": f"{n}-DOF pose" if n >= 6 else None}.get(target)
    if label is None:
        label = "spatial 3-DOF" if n == 3 else f"{n}-DOF"
    if not all(robot.is_revolute):
        label += ", prismatic"
    return label


def _round(robot, q):
    """Joint values rounded to 1 deg / 1 mm (display units), returned in SI."""
    return joints_from_display(robot, np.round(joints_to_display(robot, q)))


def _window_text(robot, window):
    """The joint window (shape (n, 2) [rad | m]) as ``name lo..hi unit`` per joint, for messages."""
    lo, hi = joints_to_display(robot, window[:, 0]), joints_to_display(robot, window[:, 1])
    return ", ".join(f"{name} {a:.4g}..{b:.4g} {'deg' if rev else 'mm'}"
                     for name, a, b, rev in zip(robot.joint_names, lo, hi, robot.is_revolute))


def _valid_branches(robot, q, window):
    """How many IK branches of FK(q) lie inside the window and reproduce the target (0: not reachable)."""
    target = target_from_pose(robot, fk(robot, q))
    try:
        sols = ik_all(robot, target)
    except LabkitError:
        return 0
    count = 0
    for qs, ok in zip(np.atleast_2d(sols.q), np.atleast_1d(sols.valid)):
        if ok and np.all(qs >= window[:, 0] - 1e-9) and np.all(qs <= window[:, 1] + 1e-9):
            count += target_error(robot, qs, target) < 1e-6
    return count


def _spread(points, count, scale):
    """Indices of ``count`` of ``points`` (shape (k, 3)) spread apart: farthest-point picking from the first."""
    chosen = [0]
    while len(chosen) < count:
        dist = np.min(np.linalg.norm(points[:, None, :] - points[chosen][None, :, :], axis=-1), axis=1) / scale
        dist[chosen] = -1.0
        chosen.append(int(np.argmax(dist)))
    return chosen


def _ik_targets(robot, kind, window, at, count=3, candidates=12, tries=200):
    """Joint poses whose FK are the lab's IK targets: well-conditioned, every branch inside the window where
    possible, spread over the workspace."""
    rng = np.random.default_rng(0)
    found = []
    for _ in range(tries):
        q = at(rng.uniform(0.2, 0.8, robot.n))
        if _conditioning(robot, q, kind) > 1.0:
            branches = _valid_branches(robot, q, window)
            if branches:
                found.append((branches, q))
                if len(found) == candidates:
                    break
    if len(found) < count:
        return [q for _, q in found]
    most = max(b for b, _ in found)
    pool = [q for b, q in found if b == most]
    if len(pool) < count:  # the targets with every branch first, then the others
        pool += [q for b, q in sorted(found, key=lambda bq: -bq[0]) if b != most][:count - len(pool)]
    points = fk(robot, np.array(pool))[:, :3, 3]
    return [pool[i] for i in _spread(points, count, max(robot_reach(robot), 1e-3))]


def _conditioning(robot, q, kind):
    """The Jacobian's smallest relevant singular value at ``q`` over 5 % of the reach: above 1 is well-conditioned."""
    J = jacobian(robot, q)
    # (a 4-DOF arm's pose targets: the position part must stay well-conditioned)
    rows = {"planar": [0, 1, 5], "pose": list(range(6)) if robot.n >= 6 else [0, 1, 2]}.get(kind, [0, 1, 2])
    s = np.linalg.svd(J[rows], compute_uv=False)
    reach = max(robot_reach(robot), 1e-3)
    return float(s[min(len(rows), robot.n) - 1] / (0.05 * reach))


def _cartesian_ok(robot, path, q_start, window, duration):
    import warnings

    from labkit.motion import cartesian_trajectory

    try:
        with warnings.catch_warnings():  # a trial path through a gimbal lock of the rpy angles: not news to the user
            warnings.filterwarnings("ignore", message="Gimbal lock", category=UserWarning)
            traj = cartesian_trajectory(robot, path, duration, dt=0.05, q_start=q_start)
    except LabkitError:
        return False
    return bool(np.all(traj.q >= window[:, 0] - 1e-9) and np.all(traj.q <= window[:, 1] + 1e-9))


def _duration(robot, plans, base=2.0, margin=1.25):
    """The moves' duration [s]: ``base``, or longer (in 0.5 s steps) where a plan would exceed (with ``margin``) a
    joint's speed limits: the robot file's, else the virtual arm's for an ideal actuator (``ideal_speed_limits``)."""
    from labkit.arm import ideal_speed_limits, is_ideal
    vmax, amax = np.array([ideal_speed_limits(robot, j) if is_ideal(lk) else (lk.max_velocity or np.inf,
                           lk.max_acceleration or np.inf) for j, lk in enumerate(robot.links)]).T
    stretch = 1.0
    for traj in plans:
        stretch = max(stretch, margin * float(np.max(np.abs(traj.qd) / vmax)),
                      math.sqrt(margin * float(np.max(np.abs(traj.qdd) / amax))))
    return math.ceil(base * stretch * 2.0 - 1e-9) / 2.0  # speeds scale as 1/T, accelerations as 1/T^2


def lab_defaults(robot) -> LabDefaults:
    """Pick lab defaults from a robot: poses, targets, moves, a line and an arc inside its servo window.

    Poses are fractions of the joint window (the limits, within a hobby servo's travel where a
    joint has one, see :func:`servo_window`; a revolute joint within a turn either side of zero),
    rounded to whole degrees / millimetres: a home pose (the first of a few spread patterns that is
    well-conditioned, else the best-conditioned one) and each joint moved both ways from it (30 % and 70 % of a
    revolute joint's window, 15 % and 85 % of a prismatic joint's travel, at least 20 % of it away from home).
    IK targets are the FK of well-conditioned poses in the middle 60 % of the window whose targets the robot's IK
    solves inside it, preferring targets with every IK branch inside the window, spread apart over the workspace
    (farthest-point picking). The line and the arc start at the home pose and are planned (IK at every sample).

    Parameters
    ----------
    robot : Robot or str
        The robot (its servo calibrations bound the window; see :func:`with_servos`).

    Returns
    -------
    LabDefaults

    Raises
    ------
    LabkitError
        The arm has no length, or no well-conditioned pose, reachable target or feasible path was
        found (the message names the robot file and the joint window).
    """
    from labkit.motion import arc_path, cartesian_trajectory, joint_trajectory, line_path

    robot = Robot.load(robot)
    who = robot.path or robot.name  # errors name the robot file
    reach = robot_reach(robot)
    if not reach > 0.0:
        raise LabkitError(f"{who}: expected an arm with a length (a non-zero a, d, prismatic travel or tool offset), "
                          f"got every length 0: its tool cannot move")
    kind = target_kind(robot)
    window = servo_window(robot)
    # a revolute joint's poses are picked within a turn either side of zero (limits such as +-3600 deg: "endless")
    turns = np.asarray(robot.is_revolute) & (window[:, 0] < 2 * math.pi) & (window[:, 1] > -2 * math.pi)
    window[turns] = np.clip(window[turns], -2 * math.pi, 2 * math.pi)
    lo, hi = window[:, 0], window[:, 1]
    n = robot.n

    def at(f):
        return _round(robot, lo + np.asarray(f, float) * (hi - lo))

    patterns = [np.array([0.5 + s * (0.12 + 0.05 * (j % 3)) * (-1) ** j for j in range(n)]) for s in (1, -1, 1.6, -1.6, 0.5)]
    # the first well-conditioned pattern; else the best-conditioned one (never the window's middle as such: with
    # symmetric limits that is q = 0, often a singular stretched-out pose)
    home = next((at(f) for f in patterns if _conditioning(robot, at(f), kind) > 1.0),
                max((at(f) for f in patterns), key=lambda q: _conditioning(robot, q, kind)))
    poses = [home]
    for j in range(n):
        # each joint away from home both ways, well inside its window, at least a fifth of it from home
        f_home = (home[j] - lo[j]) / (hi[j] - lo[j])
        for f in ((0.3, 0.7) if robot.is_revolute[j] else (0.15, 0.85)):
            q = home.copy()
            q[j] = at(np.full(n, np.clip(min(f, f_home - 0.2) if f < 0.5 else max(f, f_home + 0.2), 0.05, 0.95)))[j]
            poses.append(q)
    targets_q = _ik_targets(robot, kind, window, at)
    if len(targets_q) < 3:
        raise LabkitError(f"{who}: found no 3 well-conditioned IK targets inside the joint window "
                          f"({_window_text(robot, window)}); expected limits that leave the arm room to move")
    move = [home, targets_q[0]]
    p0 = fk(robot, home)[:3, 3]
    directions = [np.array(v, float) for v in ([1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1])]
    if kind == "planar":
        directions = directions[:4]
    arc_normals = [None]  # arcs in the x-y plane about +z
    in_plane = False  # the tool moves only in the arm's vertical plane
    if kind in REDUCED or (kind == "pose" and n < 6):
        # a 4-DOF (yaw-pitch-pitch-pitch) arm holds its orientation only where the yaw stays put:
        # lines and arcs in the vertical plane through the base axis and the tool
        # (the arm's plane: spanned by axis 1 and the radial direction axis 2 x axis 1, at the home pose);
        # a SCARA (parallel first axes, x y z yaw targets) moves freely: no plane
        axes = jacobian(robot, home)[3:, :2].T
        radial = np.cross(axes[1], axes[0])
        if np.linalg.norm(radial) > 1e-6 * max(np.linalg.norm(axes[0]) * np.linalg.norm(axes[1]), 1e-12):
            in_plane = True
            radial = radial / np.linalg.norm(radial)
            up = axes[0] / np.linalg.norm(axes[0])
            directions = [radial, -radial, up, -up]
            arc_normals = [np.cross(radial, up)]
    # display precision [mm, deg]: 0.1, except for an arm held in its vertical plane (a 4-DOF arm's pitch
    # targets), whose orientation and position must agree to 1e-6 rad (a rounded point leaves the plane),
    # and a 1-DOF arm's, on one curve: a point off it by more than the numeric IK's tolerance (1e-10 of the reach) is out of reach
    digits = 9 if n == 1 else 6 if in_plane else 1
    line_pts = arc_spec = None  # a 1-DOF arm gets neither (its notebooks that need them are left out)
    for length in (0.15, 0.1, 0.05) if n > 1 else ():
        for u in directions:
            end = p0 + length * reach * u
            if _cartesian_ok(robot, line_path(p0, end), home, window, 2.0):
                line_pts = np.round(np.array([p0, end]) * 1000.0, digits)
                break
        if line_pts is not None:
            break
    for radius in (0.1, 0.06, 0.03) if n > 1 else ():
        r = radius * reach
        for normal in arc_normals:
            u, v = arc_path(p0, r, 0.0, 1.0, normal=normal).plane_axes  # the plane's in-plane axes
            for start in (0.0, 90.0, 180.0, 270.0):
                th = math.radians(start)
                center = p0 - r * (math.cos(th) * u + math.sin(th) * v)
                for sweep in (90.0, -90.0):
                    path = arc_path(center, r, th, math.radians(sweep), normal=normal)
                    if _cartesian_ok(robot, path, home, window, 2.0):
                        arc_spec = {"center_mm": [round(float(c), digits) for c in center * 1000.0],
                                    "radius_mm": round(r * 1000.0, digits), "start_deg": start, "sweep_deg": sweep}
                        if normal is not None:
                            arc_spec["normal"] = [round(float(c), 12) for c in normal]
                        break
                if arc_spec:
                    break
            if arc_spec:
                break
        if arc_spec:
            break
    if n > 1 and (line_pts is None or arc_spec is None):
        raise LabkitError(f"{who}: found no Cartesian line/arc from the home pose "
                          f"{joints_to_display(robot, home).round(1).tolist()} inside the joint window "
                          f"({_window_text(robot, window)})")

    def disp(q):
        return [round(float(v), 1) for v in joints_to_display(robot, q)]
    plans = [joint_trajectory(robot, home, targets_q[0], 2.0, law=law, dt=0.02) for law in ("cubic", "quintic")]
    if n > 1:
        arc_path_ = arc_path(np.asarray(arc_spec["center_mm"]) / 1e3, arc_spec["radius_mm"] / 1e3, math.radians(
            arc_spec["start_deg"]), math.radians(arc_spec["sweep_deg"]), normal=arc_spec.get("normal"))
        for path in (line_path(*(line_pts / 1e3)), arc_path_):  # as the notebook plans them (dt = 0.02 s)
            plans.append(cartesian_trajectory(robot, path, 2.0, dt=0.02, q_start=home))

    params = {
        "home": disp(home),
        "poses": [disp(q) for q in poses],
        "targets": [[round(float(v), digits) for v in target_to_display(robot, fk(robot, q))]
                    for q in targets_q],
        "move": [disp(q) for q in move],
        "line_mm": None if line_pts is None else line_pts.tolist(),
        "arc": arc_spec,
        "duration": _duration(robot, plans),
        "readings": 2,
    }
    return LabDefaults(_description(robot, kind), kind, reach, params)


def _parameters_source(values, names, docs=_PARAM_DOC):
    lines = []
    for name in names:
        text = json.dumps(values[name]) if not isinstance(values[name], str) else repr(values[name]).replace("'", '"')
        lines.append(f"{name} = {text}  # {docs.get(name, '')}".rstrip(" #"))
    return "\n".join(lines)


def _render_template(nb, values, title, robot_title, docs=_PARAM_DOC):
    """Fill a template notebook: parameters cell, title placeholders."""
    import ast

    for cell in nb.cells:
        if cell.cell_type == "markdown":
            cell.source = cell.source.replace("{{LAB_TITLE}}", title).replace("{{ROBOT_TITLE}}", robot_title)
        if "parameters" in cell.metadata.get("tags", []):
            names = []
            for node in ast.parse(cell.source).body:
                if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
                    names.append(node.targets[0].id)
            cell.source = _parameters_source(values, names, docs)
    nb.metadata["title"] = title
    return nb


def template_values(robot, robot_ref, stem, defaults=None):
    """Parameter values of one lab notebook: the robot's defaults plus robot, port, files.

    Parameters
    ----------
    robot : Robot
    robot_ref : str
        How the notebook names the robot (file name inside the lab, or a bundled name).
    stem : str
        Notebook name without ``.ipynb`` (for ``output_dir``).
    defaults : LabDefaults, optional

    Returns
    -------
    dict
    """
    defaults = defaults or lab_defaults(robot)
    return {**defaults.parameters, "robot": robot_ref, "port": _virtual_port(robot, robot_ref),
            "measurements": "", "payload_kg": PAYLOAD_KG, "output_dir": f"{stem}_files"}


def _virtual_port(robot, robot_ref):
    """The notebooks' default port: the virtual arm of ``robot``, on its virtual servo bus if it has one.

    Parameters
    ----------
    robot : Robot
    robot_ref : str
        How the notebook names the robot (file name inside the lab, or a bundled name).

    Returns
    -------
    str
        ``sim://<robot_ref>?clock=lockstep&seed=0&calibrated=1`` (hobby servos, the board's
        EEPROM holding the robot file's calibration), or ``sim://<robot_ref>?bus=<protocol>&clock=lockstep&seed=0``
        (a Dynamixel or Feetech bus: the vendor SDK drives an emulated bus).

    Examples
    --------
    >>> _virtual_port(Robot.load("so101"), "robot.toml")
    'sim://robot.toml?bus=feetech&clock=lockstep&seed=0'
    """
    if robot.bus is not None:
        return f"sim://{robot_ref}?bus={robot.bus.protocol}&clock=lockstep&seed=0"
    return f"sim://{robot_ref}?clock=lockstep&seed=0&calibrated=1"


def _port_doc(robot):
    """The comment of the notebooks' ``port`` parameter: the virtual arm, and what a real one is."""
    if robot.bus is not None:
        device = {"dynamixel": "/dev/ttyUSB0", "feetech": "/dev/ttyACM0"}.get(robot.bus.protocol, "/dev/ttyUSB0")
        return (f"the virtual arm on a virtual {robot.bus.protocol} bus; a real bus: \"{robot.bus.protocol}://{device}\" "
                f"({robot.bus.protocol}://COM4 on Windows)")
    return _PARAM_DOC["port"]


def _actuator_notes(robot):
    """What the virtual arm makes of the joints of ``robot`` that have no servo (printed by ``labkit new``)."""
    ideal = [j for j, lk in enumerate(robot.links) if lk.servo is None and lk.bus is None]
    if not ideal:
        return ()
    notes = [f"{ROBOT_FILE}: your robot file, copied unchanged; the notebooks use it",
             f"Joints without a servo table ({', '.join(robot.joint_names[j] for j in ideal)}) run as ideal actuators "
             f"on the virtual arm (sim://): within the robot file's limits, at its max_velocity and max_acceleration "
             f"(the virtual arm's defaults where the file gives none). Joint ranges:"]
    for j in ideal:
        scale, unit = (180.0 / math.pi, "deg") if robot.is_revolute[j] else (1000.0, "mm")
        lo, hi = (float(v) * scale for v in robot.joint_limits[j])
        notes.append(f"  {robot.joint_names[j]}: {lo:.4g}..{hi:.4g} {unit} (the robot file's limits)")
    return tuple(notes)


def new_lab(robot, lab_dir, *, title=None, force=False) -> NewLab:
    """Create a lab folder for ``robot`` from the generic template notebooks.

    Copies the robot file to ``robot.toml`` byte for byte (comments, ranges and all) and writes
    the notebooks ``01_robot_dh``, ``02_fk_check``, ``03_ik_check``, ``04_trajectory``,
    ``05_calibration``, ``06_camera_fk_check`` (the FK check with a camera, :mod:`labkit.vision`),
    ``07_dynamics`` (:mod:`labkit.dynamics`; only for a robot file with inertias), ``08_control``
    (identification, PID, computed torque, resolved rate: :mod:`labkit.control`; only with servos or inertias; neither it nor
    ``04_trajectory`` for a 1-DOF arm, whose tool has no Cartesian line to follow) with their parameters picked by :func:`lab_defaults`, plus a ``README.md`` and the title
    page of ``labkit report`` (``lab.toml``: course, team, authors and date to fill in).
    The notebooks use ``robot.toml`` itself: a joint without a servo or bus table is an ideal
    actuator on the virtual arm (within the file's limits, at its speed limits; no servo window is
    assumed), and :attr:`NewLab.notes` says so (``labkit new`` prints it). An arm on a servo bus (a
    ``[bus]`` table) runs on its virtual bus (``port = "sim://robot.toml?bus=dynamixel&..."``, or
    ``feetech``).

    Parameters
    ----------
    robot : str or os.PathLike
        Robot file or bundled robot name.
    lab_dir : str or os.PathLike
        The folder to create.
    title : str, optional
        Lab title (default ``"<robot title> lab"``).
    force : bool
        Write into an existing non-empty folder (files of the same names are replaced).

    Returns
    -------
    NewLab

    Raises
    ------
    LabkitError
        The folder exists and is not empty (without ``force``), the robot cannot be loaded, no defaults fit it,
        or it has more joints than the board protocol carries (``labkit.arm.MAX_JOINTS``; the notebooks drive it).
    """
    import shutil
    from labkit.arm import check_joint_count
    with needs_extra("reports"):
        import nbformat

    folder = Path(lab_dir)
    if folder.exists() and any(folder.iterdir()) and not force:
        raise LabkitError(f"expected a new or empty lab folder, got {str(folder)!r} (not empty; use --force)")
    user = model = Robot.load(robot)
    check_joint_count(model)  # every notebook drives the arm: one the board protocol cannot carry gets no lab
    notes = _actuator_notes(user)
    defaults = lab_defaults(model)
    templates = sorted(TEMPLATE_DIR.glob("[0-9][0-9]_*.ipynb"))
    if not templates:
        raise LabkitError(f"no lab templates in {TEMPLATE_DIR} (reinstall labkit)")
    left_out = {tpl: why for tpl in templates  # template -> the first reason it does not apply
                if (why := next((why for stem, needs, why in _NEEDS if stem == tpl.stem and not needs(model)), None))}
    templates = [tpl for tpl in templates if tpl not in left_out]
    skipped = tuple(f"{tpl.name}: left out, {why}" for tpl, why in left_out.items())
    folder.mkdir(parents=True, exist_ok=True)
    robot_file = folder / ROBOT_FILE
    if Path(user.path).resolve() != robot_file.resolve():
        shutil.copyfile(user.path, robot_file)
    lab_file = robot_file
    title = title or f"{model.title or model.name} lab"
    written = []
    for tpl in templates:
        nb = nbformat.read(str(tpl), as_version=4)
        values = template_values(model, lab_file.name, tpl.stem, defaults)
        nb = _render_template(nb, values, title, model.title or model.name, {**_PARAM_DOC, "port": _port_doc(model)})
        written.append(folder / tpl.name)
        nbformat.write(nb, str(written[-1]))
    added = "".join(f" {line}" for line in notes[1:])
    if model.bus is not None:
        protocol = model.bus.protocol
        where = (f"virtual arm on a virtual {protocol} bus, `{_virtual_port(model, lab_file.name)}`: the vendor SDK's "
                 f"packets to an emulated bus")
        real = (f"On the real arm: `labkit run 02_fk_check.ipynb -p port "
                f"{protocol}://{'/dev/ttyUSB0' if protocol == 'dynamixel' else '/dev/ttyACM0'}`")
    else:
        where, real = "virtual arm, `sim://`", "On a real board: `labkit run 02_fk_check.ipynb -p port /dev/ttyACM0`"
    (folder / "README.md").write_text(
        f"# {title}\n\nRobot: `{ROBOT_FILE}` ({model.title or model.name}; {defaults.description}, target kind "
        f"`{defaults.target}`), made with `labkit new`.{added}\n\n"
        + "".join(f"* `{p.name}`\n" for p in written)
        + f"\nOpen in JupyterLab: `labkit lab .`; render the reports: `labkit render .` (defaults run on the "
          f"{where}). {real}.\n",
        encoding="utf-8")
    from labkit.reports import LabInfo, write_lab_info
    write_lab_info(folder, LabInfo(title=title, course="", team="", authors=(), date=""))  # title page
    return NewLab(folder.resolve(), robot_file.resolve(), tuple(p.resolve() for p in written), defaults.description,
                  lab_file.resolve(), notes + skipped)
