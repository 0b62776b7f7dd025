"""Issue 27: every bad input is a LabkitError (API) or one line and a non-zero exit status (CLI).

The probes of the issue, kept as fuzz tests sized to run in seconds: bad numbers (nan, inf, 0, -1, 1e308,
5e-324, 1e-12) and bad types at the time laws, time grids and statics; bad option values and bad files at
the command line. 0 other exceptions, 0 silent NaN, 0 tracebacks.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labkit.kinematics as kin
import labkit.motion as motion
from labkit.cli import main
from labkit.exceptions import LabkitError

BAD = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e308, -1e308, 5e-324, 1e-12, 1e-300]),
    st.floats(), st.sampled_from(["x", "", None, [1.0, 2.0], [[1.0], [2.0, 3.0]], {}, True]),
)
J6 = np.eye(6)
CALLS = {
    "cubic_law duration": lambda b: motion.cubic_law(0.0, 1.0, b),
    "quintic_law duration": lambda b: motion.quintic_law(0.0, 1.0, b),
    "linear_law duration": lambda b: motion.linear_law(0.0, 1.0, b),
    "lspb_law duration": lambda b: motion.lspb_law(0.0, 1.0, b),
    "lspb_law v_max": lambda b: motion.lspb_law(0.0, 1.0, 2.0, v_max=b),
    "lspb_law blend_time": lambda b: motion.lspb_law(0.0, 1.0, 2.0, blend_time=b),
    "cubic_law q0": lambda b: motion.cubic_law(b, 1.0, 1.0),
    "make_law duration": lambda b: motion.make_law("cubic", 0.0, 1.0, b),
    "minimum_duration distance": lambda b: motion.minimum_duration(b, v_max=1.0),
    "minimum_duration v_max": lambda b: motion.minimum_duration(1.0, v_max=b),
    "minimum_duration a_max": lambda b: motion.minimum_duration(1.0, a_max=b),
    "time_grid dt": lambda b: motion.time_grid(0.0, 1.0, b),
    "time_grid tf": lambda b: motion.time_grid(0.0, b, 0.1),
    "joint_trajectory duration": lambda b: motion.joint_trajectory(None, [0.0], [1.0], b),
    "joint_trajectory dt": lambda b: motion.joint_trajectory(None, [0.0], [1.0], 1.0, dt=b),
    "via_law times": lambda b: motion.via_law(None, [0.0, 1.0, 2.0], [0.0, 1.0, b]),
    "joint_torques wrench": lambda b: kin.joint_torques(J6, b),
    "joint_torques J": lambda b: kin.joint_torques(b, np.zeros(6)),
    "manipulability J": lambda b: kin.manipulability(b),
    "manipulability part": lambda b: kin.manipulability(J6, part=b),
    "condition_number J": lambda b: kin.condition_number(b),
    "is_singular tol": lambda b: kin.is_singular(J6, tol=b),
    "damping_factor sigma_min": lambda b: kin.damping_factor(b, 0.01, 0.05),
    "damping_factor epsilon": lambda b: kin.damping_factor(0.1, b, 0.05),
    "joint_rates twist": lambda b: kin.joint_rates(J6, b),
    "joint_rates epsilon": lambda b: kin.joint_rates(J6, np.zeros(6), epsilon=b),
    "wrench_transform_matrix p": lambda b: kin.wrench_transform_matrix(b),
}


def _has_nan(out):
    for value in (out if isinstance(out, tuple) else (out,)):
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            continue
        if arr.size and np.isnan(arr).any():
            return True
    return False


@pytest.mark.parametrize("name", sorted(CALLS))
@settings(max_examples=25, deadline=None)
@given(value=BAD)
def test_bad_api_input_is_a_labkit_error_never_a_silent_nan(name, value):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = CALLS[name](value)
    except LabkitError as exc:
        assert "expected" in str(exc), str(exc)
        return
    assert not _has_nan(out), (name, value, out)


@pytest.mark.parametrize("argv, option", [
    (["sim", "arduino_arm_3dof", "--time-scale", "-1"], "--time-scale"),
    (["sim", "arduino_arm_3dof", "--time-scale", "0"], "--time-scale"),
    (["sim", "arduino_arm_3dof", "--time-scale", "nan"], "--time-scale"),
    (["sim", "arduino_arm_3dof", "--time-scale", "inf"], "--time-scale"),
    (["render", "--timeout", "-1"], "--timeout"), (["render", "--scheduler", "garbage"], "--scheduler"),
    (["render", "-j", "0"], "--jobs"),
    (["grade", "subs", "--lab", "lab", "--cpu", "inf"], "--cpu"),
    (["grade", "subs", "--lab", "lab", "--memory", "1e-9"], "--memory"),
    (["grade", "subs", "--lab", "lab", "--scheduler", "garbage"], "--scheduler"),
    (["fk", "arduino_arm_3dof", "0", "0", "nan"], "q"),
])
def test_bad_cli_options_are_one_line_and_exit_2(capsys, argv, option):
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert err.count("\n") == 1 and "Traceback" not in err and option in err and "expected" in err, err


def _one_line_failure(capsys, argv):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code
    err = capsys.readouterr().err
    assert code not in (0, None) and "Traceback" not in err, (argv, code, err)
    assert err.strip().count("\n") == 0 or all(ln.startswith(("[", " ")) for ln in err.strip().split("\n")[:-1]), err
    return err


def test_bad_files_at_the_cli_are_one_line_errors(tmp_path, capsys):
    bad = tmp_path / "bad.ipynb"
    bad.write_text("not json")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    assert "not appear to be JSON" in _one_line_failure(capsys, ["run", str(bad), "-o", str(tmp_path / "out.ipynb")])
    _one_line_failure(capsys, ["audit", str(empty)])
    _one_line_failure(capsys, ["errors", str(empty)])
    robot = tmp_path / "arm.toml"
    robot.write_text('format = "labkit-robot/1"\nname = "x\\u0000"\n')
    assert str(robot) in _one_line_failure(capsys, ["fk", str(robot), "0"])


def test_an_unwritable_output_path_is_a_one_line_error(tmp_path, capsys):
    nb = tmp_path / "ok.ipynb"
    nb.write_text('{"cells": [], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}')
    err = _one_line_failure(capsys, ["run", str(nb), "-o", "/proc/labkit-nowhere/out.ipynb"])
    assert "nowhere" in err
