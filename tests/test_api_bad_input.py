"""A sweep of bad input over the public Python API: a LabkitError that says what was expected, or a documented result.

For each public function of rotations, kinematics, motion, dynamics, control, measure, plotting, robot and tables,
tests/api_sweep_calls.py holds a working call; tests/api_sweep.py replaces one argument at a time by the
bad values of its kind (NaN and inf in arrays, a scalar, one element too many, ragged lists, a string, None,
a dict, an empty array, True where a number belongs, zero and negative durations and rates, unknown
option strings) and runs each call under a time limit. Every variant must raise a LabkitError whose message
says what was expected (``expected`` / ``expects``), or be listed in :data:`ACCEPTED` with the reason its
result is right. No other exception, no NaN out of finite input, no hang.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from tests.api_sweep import outcome, sweep  # noqa: E402
from tests.api_sweep_calls import all_calls  # noqa: E402

BATCH = "a batch of any shape: a scalar, a longer or an empty array is a batch (the result has its shape)"
BROADCAST = "broadcasts against the other values (numpy's rules): a scalar or a shorter array is one for all"
ZERO_OK = "zero is a valid value here"
INF_UNBOUNDED = "inf is documented as 'no bound' (as None)"
PER_SEGMENT = "two segment durations: the path has two segments (one per value)"
EXTRA_COORDINATE = "one more coordinate is one more joint of a robot-free (None) call"
DIMS_3 = "the bad 'number' option of the sweep is 3, a valid dims"
INDEX = "0 and -1 are valid indices (Python's negative indexing)"
DIRECTION = "-1 is a valid direction"
TOL_TIGHTER = "a zero or negative tolerance asks for a stricter check"
PREDICATE = "a predicate: a non-finite matrix or joint value is 'not a rotation' / 'not within limits' (documented)"
ELEMENTWISE_NAN = "element-wise, like a numpy ufunc: NaN and inf in give NaN out (the IK solvers mark unreached rows NaN)"
MISSING_READING = "element-wise unit conversion: a missing reading (NaN) stays NaN, inf stays inf"
ANY_VALUE = "formats any value as a table cell: words for missing values and booleans, str() of the rest"
EMPTY_MAPPING = "an empty mapping or list: nothing to rename, mark or sweep"
EXTRA_JOINT = "one more column of a Jacobian is one more joint"
SEED = "numpy's default_rng seeds: 0, or None for fresh entropy (documented)"
SOLVER_NONE = "None picks 'auto', as the default does"

#: (call, argument) -> (bad-value labels that return a right result, why)
ACCEPTED = {
    ("rotation_x", "angle"): ({"empty"}, BATCH),
    ("rotation_y", "angle"): ({"empty"}, BATCH),
    ("rotation_z", "angle"): ({"empty", "longer", "scalar"}, BATCH),
    ("rotation_about", "angle"): ({"empty"}, BATCH),
    ("matrix_from_axis_angle", "angle"): ({"empty"}, BATCH),
    ("wrap_angle", "angle"): ({"empty", "longer", "scalar", "nan", "inf"}, f"{BATCH}; {ELEMENTWISE_NAN}"),
    ("slerp", "s"): ({"empty", "longer", "scalar"}, BATCH),
    ("is_rotation", "R"): ({"nan", "inf"}, PREDICATE),
    ("ik", "solver"): ({"none"}, SOLVER_NONE),
    ("ik_all", "solver"): ({"none"}, SOLVER_NONE),
    ("ik_numeric", "restarts"): ({"zero"}, "0 restarts: the first start only"),
    ("ik_numeric", "seed"): ({"none", "zero"}, SEED),
    ("joint_torques", "J"): ({"longer"}, EXTRA_JOINT),
    ("singular_values", "J"): ({"longer"}, EXTRA_JOINT),
    ("manipulability", "J"): ({"longer"}, EXTRA_JOINT),
    ("condition_number", "J"): ({"longer"}, EXTRA_JOINT),
    ("is_singular", "J"): ({"longer"}, EXTRA_JOINT),
    ("is_singular", "tol"): ({"zero"}, "tol 0: singular only where the smallest singular value is exactly 0"),
    ("damping_factor", "sigma_min"): ({"empty"}, BATCH),
    ("damping_factor", "max_damping"): ({"zero"}, "max_damping 0: no damping (the plain pseudo-inverse)"),
    ("joint_rates", "J"): ({"longer"}, EXTRA_JOINT),
    ("joint_rates", "max_damping"): ({"zero"}, "max_damping 0: no damping (the plain pseudo-inverse)"),
    ("workspace_points", "seed"): ({"none", "zero"}, SEED),
    ("planar_region", "close_gaps"): ({"zero"}, "0 disables the closing (documented)"),
    ("cubic_law", "q0"): ({"empty"}, BROADCAST),
    ("cubic_law", "qf"): ({"empty"}, BROADCAST),
    ("cubic_law", "v0"): ({"empty"}, BROADCAST),
    ("cubic_law", "vf"): ({"empty"}, BROADCAST),
    ("quintic_law", "q0"): ({"scalar"}, BROADCAST),
    ("quintic_law", "qf"): ({"scalar"}, BROADCAST),
    ("lspb_law", "q0"): ({"empty"}, BROADCAST),
    ("lspb_law", "qf"): ({"empty"}, BROADCAST),
    ("lspb_law", "v_max"): ({"inf"}, INF_UNBOUNDED),
    ("linear_law", "q0"): ({"empty"}, BROADCAST),
    ("linear_law", "qf"): ({"empty"}, BROADCAST),
    ("minimum_duration", "distance"): ({"empty"}, BATCH),
    ("minimum_duration", "v_max"): ({"inf"}, INF_UNBOUNDED),
    ("minimum_duration", "a_max"): ({"inf"}, INF_UNBOUNDED),
    ("TimeLaw.evaluate", "t"): ({"empty", "longer", "scalar"}, BATCH),
    ("TimeLaw.evaluate", "derivative"): ({"zero"}, "derivative 0 is the position"),
    ("TimeLaw.position", "t"): ({"empty", "longer", "scalar"}, BATCH),
    ("TimeLaw.peak", "derivative"): ({"zero"}, "derivative 0 is the position"),
    ("CartesianPath.point", "s"): ({"empty", "longer", "scalar"}, BATCH),
    ("via_law", "points"): ({"longer"}, EXTRA_COORDINATE),
    ("via_law durations", "durations"): ({"list"}, PER_SEGMENT),
    ("via_trajectory", "durations"): ({"list"}, PER_SEGMENT),
    ("heuristic_velocities", "points"): ({"longer"}, EXTRA_COORDINATE),
    ("check_speed", "tol"): ({"zero"}, ZERO_OK),
    ("path_law", "duration"): ({"list"}, "a line takes the sum of the durations given"),
    ("cartesian_trajectory", "duration"): ({"list"}, "a line takes the sum of the durations given"),
    ("cartesian_via_trajectory", "durations"): ({"list"}, PER_SEGMENT),
    ("approach_point", "height"): ({"list"}, BROADCAST),
    ("pick_and_place_legs", "height"): ({"list"}, BROADCAST),
    ("blended_law", "points"): ({"longer"}, EXTRA_COORDINATE),
    ("blended_law", "durations"): ({"list"}, PER_SEGMENT),
    ("blended_trajectory", "points"): ({"longer"}, EXTRA_COORDINATE),
    ("blended_trajectory", "v_max"): ({"list"}, "one bound per coordinate"),
    ("blended_trajectory", "a_max"): ({"list"}, "one bound per coordinate"),
    ("model_response", "zeta"): ({"zero"}, "an undamped second-order model"),
    ("rate_limited_steps", "t"): ({"empty", "longer", "scalar"}, BATCH),
    ("rate_limited_steps", "rate_limit"): ({"none"}, "None: ideal steps (documented)"),
    ("resolved_rate_trajectory", "gain"): ({"zero"}, "gain 0: pure feedforward (documented)"),
    ("joint_plant", "joint"): ({"zero"}, "joint 0 is the first joint"),
    ("MeasurementLog", "path"): ({"string"}, "'x' is a file name (the test runs in a temporary folder)"),
    ("MeasurementLog", "robot"): ({"unknown"}, "a robot name is recorded as given (documented: Robot or str or None)"),
    ("parse_numbers", "text"): ({"none", "number"}, "None is an empty cell (None); a number is its own text"),
    ("prompt_reading", "hi"): ({"inf"}, "inf: no upper bound (the default of lo is -inf)"),
    ("to_si", "value"): ({"empty", "nan", "inf"}, f"{BATCH}; {MISSING_READING}"),
    ("joint_sweep_plan", "sweeps"): ({"dict"}, EMPTY_MAPPING),
    ("ErrorTable.flagged", "tolerance"): ({"dict", "inf", "zero"},
                                          "a mapping per quantity ({}: none), inf flags nothing, 0 every error"),
    ("ErrorTable.report_table", "tolerance"): ({"dict", "inf", "zero"},
                                               "a mapping per quantity ({}: none), inf flags nothing, 0 every error"),
    ("ErrorTable.report_table", "unit"): ({"unknown"}, "the printed unit is a label: any string"),
    ("plot_arm", "dims"): ({"number"}, DIMS_3),
    ("plot_arm", "alpha"): ({"zero"}, ZERO_OK),
    ("plot_workspace", "dims"): ({"number"}, DIMS_3),
    ("animate_arm", "dims"): ({"number"}, DIMS_3),
    ("Link", "max_velocity"): ({"inf"}, "an inf given to Link is stored as None (docs/architecture.md)"),
    ("Link", "max_acceleration"): ({"inf"}, "an inf given to Link is stored as None (docs/architecture.md)"),
    ("ServoCalibration", "channel"): ({"zero"}, ZERO_OK),
    ("ServoCalibration", "direction"): ({"negative"}, DIRECTION),
    ("Gripper", "channel"): ({"zero"}, ZERO_OK),
    ("BusServo", "id"): ({"zero"}, ZERO_OK),
    ("BusServo", "direction"): ({"negative"}, DIRECTION),
    ("Bus", "protocol"): ({"unknown"}, "a well-formed protocol name is checked when the bus opens (documented)"),
    ("Bus", "latency"): ({"zero"}, ZERO_OK),
    ("LinkInertia", "mass"): ({"zero"}, "a massless link"),
    ("LinkInertia.from_matrix", "mass"): ({"zero"}, "a massless link"),
    ("Motor", "gear_ratio"): ({"negative"}, "a negative ratio turns the joint the other way (documented)"),
    ("Robot.within_limits", "q"): ({"nan", "inf"}, PREDICATE),
    ("Robot.within_limits", "tol"): ({"zero", "negative"}, TOL_TIGHTER),
    ("Robot.check_limits", "tol"): ({"zero", "negative"}, TOL_TIGHTER),
    ("Robot.with_link", "index"): ({"zero", "negative"}, INDEX),
    ("report_table", "columns"): ({"dict"}, EMPTY_MAPPING),
    ("ReportTable.mark", "rows"): ({"dict"}, EMPTY_MAPPING),
    ("ReportTable.mark", "columns"): ({"dict"}, EMPTY_MAPPING),
    ("format_value", "value"): ({"nan", "inf", "string", "none", "dict", "list", "bool"}, ANY_VALUE),
    ("format_value", "decimals"): ({"zero"}, "0 decimals: whole numbers"),
    ("latex_escape", "text"): ({"number", "none", "list"}, "escapes str(text)"),
}

#: NaN out is right only where NaN in is passed through element-wise
NAN_PASSES = {("wrap_angle", "angle"), ("to_si", "value")}

CALLS = [c for calls in all_calls().values() for c in calls]


@pytest.fixture(autouse=True)
def _in_a_temporary_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a path argument "x" is written here, not into the clone
    yield
    plt.close("all")


@pytest.mark.parametrize("c", CALLS, ids=lambda c: c.name)
def test_the_working_call_of_the_sweep_works(c):
    assert outcome(c.func, c.args, c.kwargs) == "ok"


@pytest.mark.parametrize("c", CALLS, ids=lambda c: c.name)
def test_bad_input_is_a_labkit_error_that_says_what_was_expected(c):
    failures, stale = sweep(c, ACCEPTED, nan_passes=NAN_PASSES, after=lambda: plt.close("all"))
    assert not failures, "\n".join(failures)
    assert not stale, f"accepted but no longer returning (drop them from ACCEPTED): {stale}"


def test_every_accepted_case_names_a_call_of_the_sweep():
    names = {c.name for c in CALLS}
    assert {name for name, _ in ACCEPTED} <= names
    assert len(CALLS) >= 170
