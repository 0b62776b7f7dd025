"""Kinematic calibration: fit a robot's parameters to measured positions.

:func:`calibrate` adjusts chosen parameters of a robot model (joint zero
offsets, link lengths, base offset, and optionally a gravity-sag term per
joint) so that forward kinematics of the commanded joints reproduces the
measured tool positions in the least-squares sense
(:func:`scipy.optimize.least_squares`, with the analytic derivatives of the tool
positions with respect to the parameters, read from the model's frames; finite
differences when a sag is fitted). It reports each fitted value with a
confidence interval from the Jacobian and the scatter of the poses about the fit
(the readings of one pose may share one error), the residuals before and after, and a leave-one-pose-out check
(each pose predicted by a fit that did not see it), so overfitting shows as a
leave-one-out error well above the fit residual.

Parameter names (joints and DH rows 1-based):

``offset[j]``
    zero offset of joint j [rad] (added to the DH theta; d for a prismatic joint);
``a[i]``, ``d[i]``
    DH link length / offset of row i [m];
``tool_x``, ``tool_y``, ``tool_z``, ``base_x``, ``base_y``, ``base_z``
    translation of the tool point / base frame [m];
``sag[j]``
    gravity sag of joint j [rad]: the joint yields by ``sag[j] * cos(e_j)``
    where ``e_j`` is the elevation of the line from joint j to the tool point
    (signed by the gravity torque about the joint axis, so ``sag > 0`` is a
    droop along gravity). Not representable in a robot file; reported only.

Groups: ``"joint_offsets"`` (every joint), ``"link_lengths"`` (every non-zero
``a``, revolute ``d`` and tool translation), ``"base_offset"`` (``base_x/y/z``),
``"gravity_sag"`` (joints whose axis is horizontal).

Examples
--------
>>> from labkit.data import measurement_file
>>> result = calibrate("arduino_arm_3dof", measurement_file("seed000_fk_tables1-3.csv"),
...                    params=("joint_offsets",))
>>> bool(result.rms_after < result.rms_before)
True
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from labkit.exceptions import MeasurementError, OptionError
from labkit.validation import as_batch, as_number
from labkit.measure._errormodels import ERROR_MODELS, _covariance, _shared_variance
from labkit.measure._parameters import (_NAME, GROUPS, _nominal, _numbers, _position_derivatives, apply_parameters,
                                        parameter_names)

__all__ = ["GROUPS",
    "CalibrationResult",
    "calibrate",
    "parameter_names",
    "apply_parameters",
    "predict_positions",
]

def _sag_dq(robot, q, sag, gravity):
    """Joint deflection sag_j * cos(elevation of joint j -> tool line), shape (P, n)."""
    from labkit.kinematics import fk_frames

    T = fk_frames(robot, q)
    n = robot.n
    shift = 1 if robot.convention.value == "modified" else 0
    tip = T[..., n + 1, :3, 3]
    dq = np.zeros(q.shape)
    for j in np.flatnonzero(sag):
        o = T[..., j + shift, :3, 3]
        z = T[..., j + shift, :3, 2]
        r = tip - o
        reach = np.linalg.norm(r, axis=-1)
        lever = np.sum(z * np.cross(r, gravity), axis=-1)
        dq[..., j] = sag[j] * np.where(reach > 1e-12, lever / np.where(reach > 1e-12, reach, 1.0), 0.0)
    return dq


def predict_positions(robot, q, sag=None, gravity=None):
    """Tool positions [m] of ``robot`` at commanded ``q`` with optional gravity sag.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Commanded joint values [rad, m].
    sag : array_like, shape (n,), optional
        Sag coefficients [rad] (see module docstring).
    gravity : array_like, shape (3,), optional
        Gravity direction in world coordinates; default ``-robot.up``.

    Returns
    -------
    ndarray, shape (..., 3)
        Tool positions [m].
    """
    from labkit.kinematics import fk_position

    from labkit.robot import Robot

    robot = Robot.load(robot)
    q = as_batch(q, (robot.n,), "q")
    if sag is not None and np.any(np.asarray(sag) != 0):
        g = -np.asarray(robot.up, dtype=float) if gravity is None else np.asarray(gravity, dtype=float)
        g = g / np.linalg.norm(g)
        shape = q.shape
        q2 = q.reshape(-1, robot.n)
        q = (q2 + _sag_dq(robot, q2, np.asarray(sag, dtype=float), g)).reshape(shape)
    return fk_position(robot, q)


@dataclasses.dataclass(frozen=True)
class CalibrationResult:
    """Fitted parameters, uncertainties and residuals.

    Attributes
    ----------
    names : tuple of str
        Fitted parameters (see module docstring).
    nominal, fitted, std_error, ci_low, ci_high : ndarray, shape (p,)
        In SI units (rad, m); ``ci_*`` at :attr:`confidence` (Student t,
        ``interval_dof`` degrees of freedom).
    confidence : float
    dof : int
        Residual degrees of freedom (measured components - parameters).
    errors : str
        The error model of the intervals (``"per_pose"`` or ``"independent"``, see :func:`calibrate`).
    interval_dof : int
        Degrees of freedom of the intervals: poses - parameters (``"per_pose"``) or ``dof``.
    shared_std : float
        With ``weighted=True`` and ``"per_pose"``: the standard deviation [m] added in quadrature
        to every stated uncertainty for the error a pose's readings share (0 otherwise).
    robot : Robot
        The calibrated robot (sag not included).
    sag : ndarray, shape (n,)
        Fitted sag coefficients [rad] (zeros if not fitted).
    gravity : ndarray, shape (3,)
    pose_ids : tuple of str
    q : ndarray, shape (P, n)
        Commanded joints [rad, m].
    measured : ndarray, shape (P, 3)
        Mean measured positions [m] (NaN where an axis was not measured).
    residuals_before, residuals_after, loo_residuals : ndarray, shape (P, 3)
        Model minus measured [m]: nominal model, fitted model, and the
        leave-one-pose-out prediction of each pose.
    rms_before, rms_after, loo_rms : float
        RMS over all measured components [m].
    success : bool
    message : str
    """

    names: tuple
    nominal: np.ndarray
    fitted: np.ndarray
    std_error: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    confidence: float
    dof: int
    errors: str
    interval_dof: int
    shared_std: float
    robot: object
    sag: np.ndarray
    gravity: np.ndarray
    pose_ids: tuple
    q: np.ndarray
    measured: np.ndarray
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    loo_residuals: np.ndarray
    rms_before: float
    rms_after: float
    loo_rms: float
    success: bool
    message: str

    def parameters(self):
        """Parameter table for reports (angles in deg, lengths in mm).

        Returns
        -------
        pandas.DataFrame
            One row per fitted parameter, indexed by ``parameter``, with columns
            ``unit``, ``nominal``, ``fitted``, ``change``, ``std_error``,
            ``ci_low`` and ``ci_high`` [deg or mm, as ``unit`` says].
        """
        import pandas as pd

        rows = []
        for k, name in enumerate(self.names):
            angle = name.startswith(("offset", "sag")) and not self._prismatic(name)
            f = 180 / math.pi if angle else 1000.0
            rows.append(dict(
                parameter=name, unit="deg" if angle else "mm",
                nominal=self.nominal[k] * f, fitted=self.fitted[k] * f,
                change=(self.fitted[k] - self.nominal[k]) * f, std_error=self.std_error[k] * f,
                ci_low=self.ci_low[k] * f, ci_high=self.ci_high[k] * f,
            ))
        return pd.DataFrame(rows).set_index("parameter")

    def parameters_table(self, caption=""):
        """:meth:`parameters` as a report table: each value to the decimals its smallest standard error needs.

        A column of values is otherwise printed to 3 significant digits of its largest (a 120 mm quill offset
        beside a 0.1 deg joint offset printed that joint's fit and interval as 0 .. 0).

        Parameters
        ----------
        caption : str

        Returns
        -------
        labkit.tables.ReportTable
        """
        from labkit.tables import report_table

        table = self.parameters()
        error = np.abs(table["std_error"].to_numpy(float))
        error = error[error > 0].min(initial=np.inf)
        # two significant digits of the smallest standard error, at most 6 decimals (deg, mm)
        decimals = min(6, 1 - math.floor(math.log10(error))) if math.isfinite(error) else 1
        digits = {"*": 3}
        for c in ("nominal", "fitted", "change", "ci_low", "ci_high"):  # report_table's digits: of a column's largest
            top = np.abs(table[c].to_numpy(float)).max(initial=0.0)
            digits[c] = max(3, decimals + 1 + math.floor(math.log10(top))) if top > 0 else 3
        return report_table(table, digits=digits, caption=caption)

    def _prismatic(self, name):
        m = _NAME.match(name)
        return m.group(1) == "offset" and not self.robot.links[int(m.group(2)) - 1].is_revolute

    def to_dataframe(self):
        """Residual table [mm]: per pose and axis, before / after / leave-one-out.

        Returns
        -------
        pandas.DataFrame
            One row per measured (pose, axis) pair (missing readings skipped), columns
            ``pose_id``, ``axis``, ``measured``, ``before``, ``after``,
            ``leave_one_out`` [mm].
        """
        import pandas as pd

        rows = []
        for p, pose in enumerate(self.pose_ids):
            for k, ax in enumerate("xyz"):
                if np.isnan(self.measured[p, k]):
                    continue
                rows.append(dict(pose_id=pose, axis=ax, measured=1000 * self.measured[p, k],
                                 before=1000 * self.residuals_before[p, k],
                                 after=1000 * self.residuals_after[p, k],
                                 leave_one_out=1000 * self.loo_residuals[p, k]))
        return pd.DataFrame(rows)

    def summary(self):
        """One-line text: RMS before, after and leave-one-out [mm].

        Returns
        -------
        str
            E.g. ``"RMS error 3.10 mm before, 0.52 mm after calibration, ..."``.
        """
        return (f"RMS error {1000 * self.rms_before:.2f} mm before, {1000 * self.rms_after:.2f} mm after "
                f"calibration, {1000 * self.loo_rms:.2f} mm leave-one-pose-out "
                f"({len(self.names)} parameters, {self.dof} residual degrees of freedom)")

    def predict(self, q):
        """Tool positions [m] of the calibrated model (with sag) at commanded ``q``.

        Parameters
        ----------
        q : array_like, shape (..., n)
            Commanded joint values [rad, m].

        Returns
        -------
        ndarray, shape (..., 3)
            Predicted tool positions in the base frame [m].
        """
        return predict_positions(self.robot, q, self.sag, self.gravity)

    def write_robot(self, path, *, name=None, length_unit=None, angle_unit=None):
        """Write the calibrated robot file (returns its text).

        A comment header records the fit; a fitted gravity sag cannot be
        stored in a robot file and is listed in the header only.

        Parameters
        ----------
        path : str or os.PathLike
            File to write (overwritten).
        name : str, optional
            Robot name in the file; default ``"<robot name>_calibrated"``.
        length_unit, angle_unit : str, optional
            Units to declare in the file ("m"/"mm"/"cm", "rad"/"deg"); default:
            the units the nominal robot was loaded with.

        Returns
        -------
        str
            The text written (comment header followed by the TOML robot file).
        """
        from pathlib import Path

        robot = self.robot.replace(
            name=name or f"{self.robot.name}_calibrated",
            title=f"{self.robot.title} (calibrated)".strip(),
            source=f"{self.robot.source}; calibrated by labkit.measure".strip("; "),
        )
        header = [f"# Calibrated by labkit.measure: {self.summary()}."]
        for k, name_k in enumerate(self.names):
            header.append(f"# {name_k}: {self.nominal[k]:.6g} -> {self.fitted[k]:.6g} "
                          f"({100 * self.confidence:g}% CI {self.ci_low[k]:.6g} .. {self.ci_high[k]:.6g}) [SI]")
        if np.any(self.sag):
            header.append("# gravity sag (not stored in the file) [rad]: "
                          + ", ".join(f"joint {j + 1}: {s:.4g}" for j, s in enumerate(self.sag) if s))
        text = "\n".join(header) + "\n" + robot.to_toml(length_unit=length_unit, angle_unit=angle_unit)
        Path(path).write_text(text)
        return text


def _pose_data(measurements, robot):
    """(pose_ids, q (P, n), measured (P, 3) [m], sigma (P, 3) [m]) from readings."""
    import pandas as pd

    from labkit.measure._errortables import error_table
    from labkit.measure._schema import UNITS
    from labkit.measure._csv import load_measurements

    df = measurements if isinstance(measurements, pd.DataFrame) else load_measurements(measurements)
    df = df[df["quantity"].isin(["x", "y", "z"])]
    if not len(df):
        raise MeasurementError("expected position readings (quantities x, y, z) to calibrate against, got none")
    table = error_table(robot, df, mode="fk").table
    pose_ids = tuple(dict.fromkeys(table["pose_id"]))
    commanded = {}
    for pose, cmd in zip(df["pose_id"].tolist(), df["commanded"].tolist()):
        commanded.setdefault(pose, cmd)  # (a pose's first row)
    q = np.array([commanded[p] for p in pose_ids], dtype=float)
    measured = np.full((len(pose_ids), 3), np.nan)
    sigma = np.full((len(pose_ids), 3), np.nan)
    index = {p: i for i, p in enumerate(pose_ids)}
    for pose, quantity, unit, mean, u in zip(*(table[c].tolist() for c in ("pose_id", "quantity", "unit", "mean",
                                                                           "uncertainty"))):
        f = UNITS[unit][1]
        measured[index[pose], "xyz".index(quantity)] = mean * f
        sigma[index[pose], "xyz".index(quantity)] = u * f
    return pose_ids, q, measured, sigma


def calibrate(robot, measurements, *, params=("joint_offsets", "link_lengths"),
              weighted=False, gravity=None, confidence=0.95, leave_one_out=True, errors="per_pose"):
    """Least-squares fit of robot parameters to measured tool positions.

    Parameters
    ----------
    robot : Robot or str or None
        Nominal model (or its name or file); ``None``: the robot named in the
        measurements (a tuple of synthetic data needs a robot).
    measurements : pandas.DataFrame or str or os.PathLike, or tuple
        Readings with commanded joints (see :mod:`labkit.measure`); or a
        tuple ``(q (P, n) [rad, m], positions (P, 3) [m])`` of synthetic data
        (NaN marks an axis not measured).
    params : sequence of str
        Groups and/or parameter names (see module docstring).
    weighted : bool
        Weight each residual by 1 / its measurement uncertainty (resolution
        combined with the half range); default unweighted. With ``"per_pose"`` errors
        the fit is repeated with the pose-shared error (``shared_std``) added in quadrature.
    gravity : array_like, shape (3,), optional
        Gravity direction in world coordinates (for ``sag``); default
        ``-robot.up``, the robot file's ``up`` key (the seed 000 arm's frame 0
        has z pointing down, so its gravity is ``(0, 0, 1)``). Only the sign
        of the fitted sag depends on it.
    confidence : float
        Level of the confidence intervals.
    leave_one_out : bool
        Also refit once per pose with that pose left out.
    errors : {"per_pose", "independent"}
        Error model of the intervals (:mod:`labkit.measure._errormodels`): ``"per_pose"``
        (default) lets the readings of one pose share an error (a joint stopped in its
        deadband) and takes the uncertainty from how the poses scatter (needs more poses
        than parameters + 1, else a warning and ``"independent"``); ``"independent"``
        takes every measured component as independent (too narrow when they share one).

    Returns
    -------
    CalibrationResult

    Raises
    ------
    MeasurementError
        Fewer measured components than parameters, unknown parameter names.

    Warns
    -----
    UserWarning
        When the parameters are not all identifiable from the data (singular
        Jacobian); their intervals are then infinite.
    """
    from scipy.optimize import least_squares
    from scipy.stats import t as student_t

    from labkit.kinematics import fk_position_with
    from labkit.robot import Robot

    if isinstance(measurements, tuple):
        if robot is None:
            raise OptionError("expected a robot with synthetic (q, positions) data, got None")
        q, measured, robot = *(np.asarray(v, dtype=float) for v in measurements), Robot.load(robot)
        pose_ids = tuple(f"pose{i + 1}" for i in range(len(q)))
        sigma = np.ones_like(measured)
    else:
        from labkit.measure._calculated import _robot
        from labkit.measure._csv import load_measurements
        import pandas as pd

        if not isinstance(measurements, pd.DataFrame):
            measurements = load_measurements(measurements)
        robot = _robot(robot, measurements)
        pose_ids, q, measured, sigma = _pose_data(measurements, robot)
    if q.ndim != 2 or q.shape[1] != robot.n or measured.shape != (len(q), 3):
        raise MeasurementError(f"expected q (P, {robot.n}) and positions (P, 3), got {q.shape} and {measured.shape}")
    if not 0 < as_number(confidence, "confidence", error=MeasurementError) < 1:
        raise MeasurementError(f"expected confidence in (0, 1), got {confidence!r}")
    if not isinstance(errors, str) or errors not in ERROR_MODELS:
        raise MeasurementError(f"unknown errors={errors!r}; expected one of {ERROR_MODELS}")
    names = parameter_names(robot, params)
    nominal = np.array([_nominal(robot, nm) for nm in names])
    sag_index = [k for k, nm in enumerate(names) if nm.startswith("sag")]
    sag_joint = [int(_NAME.match(names[k]).group(2)) - 1 for k in sag_index]
    g = -np.asarray(robot.up, dtype=float) if gravity is None else np.asarray(gravity, dtype=float)
    if g.shape != (3,) or not np.all(np.isfinite(g)) or not np.linalg.norm(g) > 0:
        raise MeasurementError(f"expected gravity as a non-zero direction of shape (3,), got {np.asarray(gravity).tolist()!r}")
    g = g / np.linalg.norm(g)
    weights = 1.0 / sigma if weighted else np.ones_like(measured)

    def model(x, qs):
        sag = np.zeros(robot.n)
        sag[sag_joint] = x[sag_index]
        if np.any(sag):  # the joints sag by an amount that depends on the fitted robot's frames
            return predict_positions(apply_parameters(robot, names, x), qs, sag, g)
        return fk_position_with(robot, qs, **_numbers(robot, names, x))

    last = {}  # without a sag: the derivatives found with the last residuals, which scipy asks for next (same x)

    def residuals(x, rows):
        if sag_index:
            positions = model(x, q[rows])
        else:
            positions, last["derivatives"] = _position_derivatives(robot, names, x, q[rows])
            last["at"] = (x.tobytes(), rows)
        res = (positions - measured[rows]) * weights[rows]
        return res[~np.isnan(res)]

    def derivatives(x, rows):  # d residuals / d x, the rows of residuals(x, rows)
        at = last.get("at")
        if at is None or at[1] is not rows or at[0] != x.tobytes():
            residuals(x, rows)
        w = weights[rows]
        return (last["derivatives"] * w[:, :, None])[~np.isnan(measured[rows] * w)]

    # analytic derivatives unless a sag is fitted (the sag's joint deflections move with every parameter)
    jac = "2-point" if sag_index else derivatives

    all_rows = np.arange(len(q))
    m = int(np.sum(~np.isnan(measured)))
    p = len(names)
    if m <= p:
        raise MeasurementError(f"expected more measured components than parameters, got {m} for {p} parameters {names}")
    if errors == "per_pose" and len(q) <= p + 1:
        warnings.warn(f"{len(q)} poses for {p} parameters: too few to estimate a per-pose error, the intervals "
                      "take every measured component as independent (errors='independent')", UserWarning, stacklevel=2)
        errors = "independent"
    sol = least_squares(residuals, nominal, args=(all_rows,), jac=jac, x_scale="jac", method="trf")
    dof = m - p
    shared = 0.0
    if weighted and errors == "per_pose":
        # the stated uncertainties leave out what a pose's readings share: add that variance to
        # every component (estimated from the scatter of the poses), so no pose weighs more than it knows
        mask = ~np.isnan(measured * weights)
        shared = _shared_variance((model(sol.x, q) - measured)[mask], sigma[mask], dof)
        if shared > 0:
            weights = 1.0 / np.sqrt(sigma ** 2 + shared)
            sol = least_squares(residuals, sol.x, args=(all_rows,), jac=jac, x_scale="jac", method="trf")
        shared = math.sqrt(shared)
    J = sol.jac
    _, sv, vt = np.linalg.svd(J, full_matrices=False)
    if sv[-1] <= sv[0] * 1e-9:
        weak = [names[k] for k in np.flatnonzero(np.abs(vt[-1]) > 0.1)]
        warnings.warn(f"calibration parameters not identifiable from these measurements: {weak}", UserWarning, stacklevel=2)
        cov, interval_dof = np.full((p, p), np.inf), dof
    else:
        pose_of = np.broadcast_to(all_rows[:, None], measured.shape)[~np.isnan(measured * weights)]
        cov, interval_dof = _covariance(J, sol.fun, pose_of, errors)
    std = np.sqrt(np.diag(cov))
    half = student_t.ppf(0.5 + confidence / 2, interval_dof) * std
    fitted = sol.x

    before = model(nominal, q) - measured
    after = model(fitted, q) - measured
    loo = np.full_like(measured, np.nan)
    if leave_one_out:
        for i in range(len(q)):
            keep = all_rows[all_rows != i]
            if int(np.sum(~np.isnan(measured[keep]))) <= p:
                continue
            s = least_squares(residuals, fitted, args=(keep,), jac=jac, x_scale="jac", method="trf")
            loo[i] = model(s.x, q[i:i + 1])[0] - measured[i]

    def rms(r):
        v = r[~np.isnan(r)]
        return float(np.sqrt(np.mean(v ** 2))) if v.size else float("nan")

    sag = np.zeros(robot.n)
    sag[sag_joint] = fitted[sag_index]
    return CalibrationResult(
        names=names, nominal=nominal, fitted=fitted, std_error=std,
        ci_low=fitted - half, ci_high=fitted + half, confidence=float(confidence), dof=dof,
        errors=errors, interval_dof=int(interval_dof), shared_std=float(shared),
        robot=apply_parameters(robot, names, fitted), sag=sag, gravity=g,
        pose_ids=pose_ids, q=q, measured=measured,
        residuals_before=before, residuals_after=after, loo_residuals=loo,
        rms_before=rms(before), rms_after=rms(after), loo_rms=rms(loo),
        success=bool(sol.success), message=str(sol.message),
    )
