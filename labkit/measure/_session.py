"""Measurement sessions: move through a plan of poses and log repeated readings.

For each pose of a plan the session commands the arm (:class:`labkit.arm.Arm`),
waits until the feedback says it has settled, then records repeated readings
into a crash-safe :class:`labkit.measure.MeasurementLog` (every reading is
on disk before the next one is taken). Readings come from

* ``"ruler"``: the virtual arm's ruler (tool position x, y, z in mm, ± 0.5 mm,
  seed 000's ruler; :attr:`labkit.arm.Arm.virtual_model`), only on a simulated
  arm (``sim://``, ``simavr://?physics=...``);
* ``"feedback"``: the feedback potentiometers (``theta<i>`` in deg, ± one ADC count);
* ``"manual"``: a person types them: :func:`prompt_reading` in a terminal
  (``input()`` with validation), or :func:`manual_form` in a notebook
  (ipywidgets, event driven: it never blocks the kernel).

The log feeds :func:`labkit.measure.error_table` and
:func:`labkit.measure.calibrate` directly.

Examples
--------
>>> import tempfile, pathlib
>>> from labkit.arm import Arm
>>> path = pathlib.Path(tempfile.mkdtemp()) / "sweep.csv"
>>> plan = joint_sweep_plan("arduino_arm_3dof", {1: [45.0, 90.0]})
>>> with Arm("arduino_arm_3dof", "sim://?clock=lockstep&seed=0") as arm:
...     df = MeasurementSession(arm, path, source="ruler", readings=2).run(plan)
>>> len(df), sorted(df["quantity"].unique())
(12, ['x', 'y', 'z'])
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.robot import Robot
from labkit.exceptions import DeviceError, MeasurementError, OptionError, needs_extra
from labkit.validation import as_batch, as_count, as_vector

__all__ = [
    "Source",
    "PlannedPose",
    "MeasurementSession",
    "joint_sweep_plan",
    "SEED000_SWEEPS",
    "prompt_reading",
    "manual_form",
]

#: seed 000, section II.4: joint sweeps in degrees (the other joints at 0); tables 1-3
SEED000_SWEEPS = {1: (5.0, 45.0, 60.0, 90.0, 120.0), 2: (5.0, 45.0, 60.0, 90.0, 120.0), 3: (5.0, 20.0, 45.0, 60.0, 80.0)}
RULER_RESOLUTION_MM = 0.5


class Source(str, Enum):
    """Where readings come from."""

    RULER = "ruler"
    FEEDBACK = "feedback"
    MANUAL = "manual"


@dataclass(frozen=True)
class PlannedPose:
    """One pose of a measurement plan: id and commanded joints ``q`` [rad]."""

    pose_id: str
    q: tuple


def joint_sweep_plan(robot, sweeps, *, rest=None):
    """Poses that sweep one joint at a time (the others at ``rest``).

    Parameters
    ----------
    robot : Robot or str
    sweeps : mapping
        ``{joint number (1-based): angles in degrees}`` (seed 000's tables
        1-3: :data:`SEED000_SWEEPS`).
    rest : array_like, shape (n,), optional
        Joint values of the joints not swept [rad] (default zeros).

    Returns
    -------
    list of PlannedPose
        Ids ``"j<joint>_<deg>"`` (e.g. ``"j2_45"``).

    Examples
    --------
    >>> [p.pose_id for p in joint_sweep_plan("arduino_arm_3dof", {3: [5, 20]})]
    ['j3_5', 'j3_20']
    """
    robot = Robot.load(robot)
    rest = np.zeros(robot.n) if rest is None else as_vector(rest, robot.n, "rest")
    if not isinstance(sweeps, Mapping):
        raise OptionError(f"expected sweeps as a mapping {{joint number: angles [deg]}}, got {sweeps!r}")
    plan = []
    for joint, angles in sweeps.items():
        if not 1 <= int(joint) <= robot.n:
            raise OptionError(f"expected joint numbers 1..{robot.n}, got {joint}")
        for deg in angles:
            q = rest.copy()
            q[int(joint) - 1] = math.radians(float(deg))
            plan.append(PlannedPose(f"j{int(joint)}_{float(deg):g}", tuple(float(v) for v in q)))
    return plan


def _validate_reading(text, lo, hi):
    try:
        value = float(str(text).strip().replace(",", "."))
    except ValueError:
        raise MeasurementError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise MeasurementError(f"expected a finite number, got {text!r}")
    if not lo <= value <= hi:
        raise MeasurementError(f"expected a value between {lo:g} and {hi:g}, got {value:g}")
    return value


def prompt_reading(label, unit, *, lo=-math.inf, hi=math.inf, input=input, attempts=5):
    """Ask a person for one reading until it is a valid number in ``[lo, hi]``.

    Parameters
    ----------
    label : str
        What to read (``"j1_45 x"``).
    unit : str
        Unit shown in the prompt (``"mm"``).
    lo, hi : float
        Accepted range, in ``unit``.
    input : callable
        The prompt function (``input`` in a terminal or a notebook).
    attempts : int
        Prompts before giving up.

    Returns
    -------
    float
        The reading, in ``unit``.

    Raises
    ------
    MeasurementError
        No valid reading after ``attempts`` prompts.

    Examples
    --------
    >>> answers = iter(["abc", "12,5"])
    >>> prompt_reading("p1 x", "mm", lo=0, hi=500, input=lambda prompt: next(answers))
    expected a number, got 'abc'; try again
    12.5
    """
    attempts = as_count(attempts, "attempts", minimum=1)
    low, high = (as_batch(v, (), name, finite=False) for v, name in ((lo, "lo"), (hi, "hi")))
    if low.ndim or high.ndim or not low < high:
        raise OptionError(f"expected numbers lo < hi (inf: no bound), got lo={lo!r}, hi={hi!r}")
    lo, hi = float(low), float(high)
    for _ in range(attempts):
        text = input(f"{label} [{unit}]: ")
        try:
            return _validate_reading(text, lo, hi)
        except MeasurementError as exc:
            print(f"{exc}; try again")
    raise MeasurementError(f"no valid reading for {label} after {attempts} attempts")


class MeasurementSession:
    """Measure a plan of poses on an arm and log the readings.

    Parameters
    ----------
    arm : labkit.arm.Arm
    log : MeasurementLog or str or os.PathLike
        The log (or its path: a log is opened with the arm's robot).
    source : {"ruler", "feedback", "manual"}
    readings : int
        Repeated readings per pose and quantity (seed 000: 3).
    settle_tol : float or array_like, shape (n,), optional
        Sensed joints within this of the command count as arrived [rad | m]; default the arm's
        :func:`labkit.arm.settle_tolerance` (1 deg, 1 mm, or three coarser feedback counts).
    settle_time : float
        Extra wait after arrival, for the servos to stop [s].
    unit : {"mm", "cm", "m"}
        Unit of manual position readings (ruler readings are logged in mm).
    input : callable
        Prompt function for ``source="manual"``.
    operator : str
    """

    def __init__(self, arm, log, *, source="ruler", readings=3, settle_tol=None, settle_time=0.5,
                 unit="mm", input=input, operator=""):
        from labkit.measure._log import MeasurementLog

        try:
            self.source = Source(source)
        except ValueError:
            raise OptionError(f"expected source one of {[s.value for s in Source]}, got {source!r}") from None
        if unit not in ("mm", "cm", "m"):
            raise OptionError(f"expected unit one of mm, cm, m, got {unit!r}")
        self.arm = arm
        self.robot = arm.robot
        self.log = log if isinstance(log, MeasurementLog) else MeasurementLog(arm.robot, log,
                                                                               operator=operator)
        self.readings = int(readings)
        if self.readings < 1:
            raise OptionError(f"expected readings >= 1, got {readings}")
        self.settle_tol = settle_tol
        self.settle_time = settle_time
        self.unit = unit
        self.input = input
        if self.source is Source.RULER and self.arm.virtual_model is None:
            raise DeviceError("the ruler source needs a simulated arm (sim://); on a real arm use "
                              "source='manual' and a real ruler")

    def goto(self, q):
        """Move to ``q`` [rad] and wait until settled; returns the sensed joints [rad].

        Waits ``settle_time`` [s of board time] more after the joints settle within
        ``settle_tol``.

        Parameters
        ----------
        q : array_like, shape (n,)
            Joint values [rad].

        Returns
        -------
        ndarray, shape (n,)
            Joint values sensed at settling [rad].

        Raises
        ------
        JointLimitError
            ``q`` outside the joint limits or servo ranges (nothing is sent).
        DeviceError
            The move failed or the joints did not settle.
        """
        self.arm.move_joints(q)
        sensed = self.arm.wait_settled(np.asarray(q, float), tol=self.settle_tol)
        self.arm.sleep(self.settle_time)
        return sensed

    def measure(self, pose):
        """Move to one :class:`PlannedPose` and record its readings; returns the records.

        ``readings`` repeats per pose, from the session's source: the simulated
        ruler (x, y, z [mm]), the servo feedback (``theta<i>`` [deg]) or a person
        typing ruler readings (x, y, z in ``unit``).

        Parameters
        ----------
        pose : PlannedPose
            Pose id and joint values [rad].

        Returns
        -------
        list of MeasurementRecord
            The records appended to ``log``, in order.

        Raises
        ------
        JointLimitError, DeviceError
            As for :meth:`goto`.
        MeasurementError
            A person gave no valid reading (typed source).
        """
        q = np.asarray(pose.q, dtype=float)
        self.goto(q)
        records = []
        if self.source is Source.RULER:
            for _ in range(self.readings):
                p = self.arm.virtual_model.ruler(1)[0] * 1e3
                for axis, v in zip("xyz", p):
                    records.append(self.log.record(pose.pose_id, axis, float(v), unit="mm", instrument="ruler",
                                                   resolution=RULER_RESOLUTION_MM, commanded=q))
                self.arm.sleep(0.2)  # a person takes a few seconds; the board keeps running
        elif self.source is Source.FEEDBACK:
            # one ADC count of a hobby servo's feedback pot, or one tick of a bus servo's encoder [deg]
            res = [360.0 / lk.bus.resolution if lk.bus is not None
                   else math.degrees(abs(float(lk.servo.joint_from_adc(1.0) - lk.servo.joint_from_adc(0.0))))
                   for lk in self.robot.links]
            for _ in range(self.readings):
                sensed = np.degrees(self.arm.read_joints())
                for j, v in enumerate(sensed):
                    records.append(self.log.record(pose.pose_id, f"theta{j + 1}", float(v), unit="deg",
                                                   instrument="servo feedback", resolution=res[j], commanded=q))
                self.arm.sleep(0.05)
        else:
            reach = float(np.sum(np.abs(self.robot.a)) + np.sum(np.abs(self.robot.d))
                          + np.linalg.norm(self.robot.tool[:3, 3]))
            scale = {"mm": 1e3, "cm": 1e2, "m": 1.0}[self.unit]
            res = RULER_RESOLUTION_MM * scale / 1e3
            for k in range(self.readings):
                for axis in "xyz":
                    v = prompt_reading(f"{pose.pose_id} {axis} (reading {k + 1}/{self.readings})", self.unit,
                                       lo=-1.5 * reach * scale, hi=1.5 * reach * scale, input=self.input)
                    records.append(self.log.record(pose.pose_id, axis, v, unit=self.unit, instrument="ruler",
                                                   resolution=res, commanded=q))
        return records

    def run(self, plan, *, progress=None):
        """Measure every pose of ``plan`` (list of :class:`PlannedPose`); returns the session's table.

        Parameters
        ----------
        plan : sequence of PlannedPose
            Poses in measuring order.
        progress : callable, optional
            ``progress(done, total, pose_id)`` after each pose.

        Returns
        -------
        pandas.DataFrame
            ``log.to_dataframe()``: this session's readings, one row each.
        """
        for k, pose in enumerate(plan):
            self.measure(pose)
            if progress is not None:
                progress(k + 1, len(plan), pose.pose_id)
        return self.log.to_dataframe()


def manual_form(session, plan):
    """A notebook form for typed readings (ipywidgets; event driven, never blocks the kernel).

    Shows the current pose; "Move" sends the arm there, "Record" validates the
    x/y/z fields and logs them (one repeat), and after ``session.readings``
    repeats the form moves on to the next pose.

    Parameters
    ----------
    session : MeasurementSession
        Provides the arm (``goto``), the log, ``unit`` and ``readings``.
    plan : sequence of PlannedPose
        Poses in measuring order.

    Returns
    -------
    ipywidgets.VBox
    """
    with needs_extra("lab"):
        import ipywidgets as w

    state = {"k": 0, "repeat": 0}
    scale = {"mm": 1e3, "cm": 1e2, "m": 1.0}[session.unit]
    fields = {a: w.Text(description=f"{a} [{session.unit}]") for a in "xyz"}
    title = w.HTML()
    message = w.HTML()
    move = w.Button(description="Move")
    record = w.Button(description="Record", button_style="primary")

    def show():
        if state["k"] >= len(plan):
            title.value = "<b>All poses measured.</b>"
            move.disabled = record.disabled = True
            return
        pose = plan[state["k"]]
        title.value = (f"<b>{pose.pose_id}</b>: q = {np.round(np.degrees(pose.q), 1).tolist()} deg, "
                       f"reading {state['repeat'] + 1}/{session.readings}")

    def on_move(_):
        try:
            session.goto(np.asarray(plan[state["k"]].q))
            message.value = "arrived"
        except Exception as exc:  # noqa: BLE001 - shown to the person at the form
            message.value = f"<span style='color:red'>{exc}</span>"

    def on_record(_):
        pose = plan[state["k"]]
        try:
            values = {a: _validate_reading(f.value, -2.0 * scale, 2.0 * scale) for a, f in fields.items()}
        except MeasurementError as exc:
            message.value = f"<span style='color:red'>{exc}</span>"
            return
        for a, v in values.items():
            session.log.record(pose.pose_id, a, v, unit=session.unit, instrument="ruler",
                               resolution=RULER_RESOLUTION_MM * scale / 1e3, commanded=np.asarray(pose.q))
        for f in fields.values():
            f.value = ""
        message.value = "saved"
        state["repeat"] += 1
        if state["repeat"] >= session.readings:
            state["k"], state["repeat"] = state["k"] + 1, 0
        show()

    move.on_click(on_move)
    record.on_click(on_record)
    show()
    return w.VBox([title, *fields.values(), w.HBox([move, record]), message])
