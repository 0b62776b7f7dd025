"""``labkit new``: a lab for any arm from the generic templates, rendered like the seed labs.

Robots of different kinds: bundled ones (spatial 3-DOF servo arm, planar 3R, 6-DOF PUMA with poses
as targets, RPP with two prismatic joints, the Cobra 600 SCARA (RRPR), a PPP gantry), test
fixtures (a cylindrical RPP arm, a planar RP arm: ``tests/labs/robots``) and two written only here
(a 4-DOF yaw-pitch-pitch-pitch arm and a SCARA with a prismatic quill). The robot files without
servo tables run as ideal actuators on the virtual arm. Eight labs are scaffolded and all their
notebooks execute on the virtual arm (``sim://``) in one ``render`` batch (2 workers, no PDF);
every notebook ends with ``Checks.assert_all()``, so a rendered notebook that is ok passed all
its checks.
"""

import ast
import json
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import require
from labkit.exceptions import LabkitError

TEMPLATES = ["01_robot_dh", "02_fk_check", "03_ik_check", "04_trajectory", "05_calibration", "06_camera_fk_check",
             "07_dynamics", "08_control"]
#: the notebooks of a lab whose robot file has no inertias (the dynamics notebook is left out)
WITHOUT_INERTIAS = [t for t in TEMPLATES if t != "07_dynamics"]

YPP4 = """format = "labkit-robot/1"
name = "ypp4_test"
title = "4-DOF yaw-pitch-pitch-pitch arm (test only)"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
name = "yaw"
d = 80
alpha = 90
limits = [-150, 150]

[[joint]]
name = "shoulder"
a = 120
limits = [-10, 170]

[[joint]]
name = "elbow"
a = 100
limits = [-150, 150]

[[joint]]
name = "wrist"
a = 60
limits = [-120, 120]
"""

SCARA = """format = "labkit-robot/1"
name = "scara_test"
title = "SCARA RRP with a prismatic quill (test only)"
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
name = "shoulder"
d = 200
a = 150
limits = [-120, 120]

[[joint]]
name = "elbow"
a = 120
alpha = 180
limits = [-140, 140]

[[joint]]
name = "quill"
type = "prismatic"
limits = [20, 120]
"""

#: the test fixtures: a cylindrical RPP arm and a planar 2-DOF arm with a prismatic joint (limits, no servo tables)
FIXTURES = Path(__file__).parent / "robots"

DESCRIPTIONS = {"arduino_arm_3dof": "spatial 3-DOF", "planar3r_seed003": "planar 3-DOF", "puma560": "6-DOF pose",
                "rpp_seed002": "spatial 3-DOF, prismatic", "ypp4": "4-DOF", "scara": "spatial 3-DOF, prismatic",
                "cobra600_scara": "4-DOF, prismatic", "gantry_ppp": "spatial 3-DOF, prismatic",
                "cylindrical_rpp": "spatial 3-DOF, prismatic", "planar_rp": "2-DOF, prismatic"}
#: the arms whose labs are rendered (the SCARA RRPR, RPP, PPP and planar RP arms of issue 42 among them)
RENDERED = ["arduino_arm_3dof", "planar3r_seed003", "puma560", "ypp4", "cobra600_scara", "gantry_ppp",
            "cylindrical_rpp", "planar_rp"]


@pytest.fixture
def robot_files(tmp_path):
    files = {}
    for name, text in (("ypp4", YPP4), ("scara", SCARA)):
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        files[name] = str(path)
    return {"arduino_arm_3dof": "arduino_arm_3dof", "planar3r_seed003": "planar3r_seed003", "puma560": "puma560",
            "rpp_seed002": "rpp_seed002", **files, "cobra600_scara": "cobra600_scara", "gantry_ppp": "gantry_ppp",
            "cylindrical_rpp": str(FIXTURES / "cylindrical_rpp.toml"), "planar_rp": str(FIXTURES / "planar_rp.toml")}


def test_templates_carry_parameters_and_assignment_tags():
    nbformat = require("nbformat")
    from labkit.labs._new import TEMPLATE_DIR

    assert sorted(p.stem for p in TEMPLATE_DIR.glob("*.ipynb")) == TEMPLATES
    for stem in TEMPLATES:
        nb = nbformat.read(str(TEMPLATE_DIR / f"{stem}.ipynb"), as_version=4)
        tags = [t for c in nb.cells for t in c.metadata.get("tags", [])]
        assert tags.count("parameters") == 1 and {"solution", "tests", "hidden-tests"} <= set(tags), (stem, tags)
        text = "\n".join(c.source for c in nb.cells)
        assert "seed" not in nb.cells[0].source.lower(), "templates are generic, not copies of the seed labs"
        assert "{{LAB_TITLE}}" in nb.cells[0].source and "assert_all()" in nb.cells[-1].source
        assert "from labkit." in text and "._" not in text.replace("._files", ""), "public labkit names only"


def test_lab_defaults_pick_the_robot_kind_and_reachable_targets(robot_files):
    from labkit.kinematics import fk, ik_all
    from labkit.robot import joints_from_display, robot_reach, servo_window
    from labkit.labs import lab_defaults
    from labkit.kinematics import target_error, target_from_display
    from labkit.robot import Robot

    for key, ref in robot_files.items():
        robot = Robot.load(ref)
        d = lab_defaults(robot)
        assert d.description == DESCRIPTIONS[key], key
        window = servo_window(robot)  # the robot file's limits where a joint has no servo (an ideal actuator)
        if all(lk.servo is None and lk.bus is None for lk in robot.links):
            assert np.array_equal(window, robot.joint_limits), key
        poses = joints_from_display(robot, d.parameters["poses"])
        for q in poses:
            assert np.all(q >= window[:, 0] - 1e-9) and np.all(q <= window[:, 1] + 1e-9), key
        travel = np.ptp(poses, axis=0) / np.ptp(window, axis=1)  # each joint is moved over much of its window
        assert np.all(travel[robot.is_revolute] >= 0.39) and np.all(travel[~robot.is_revolute] >= 0.69), (key, travel)
        points = []
        for row in d.parameters["targets"]:
            goal = target_from_display(robot, row)
            sols = ik_all(robot, goal)
            errors = [target_error(robot, q, goal) for q, ok in zip(np.atleast_2d(sols.q), np.atleast_1d(sols.valid)) if ok]
            # targets are printed to 0.1 mm / 0.1 deg: the IK of the printed target reaches it exactly
            assert errors and min(errors) < 1e-6, (key, row)
            if key == "cobra600_scara":  # both elbows of every SCARA target inside the limits (03 shows them)
                assert sols.branches == ("elbow_left", "elbow_right") and np.all(sols.valid), row
            points.append(fk(robot, np.atleast_2d(sols.q)[0])[:3, 3])
        points = np.array(points)
        gaps = [np.linalg.norm(points[i] - points[k]) for i in range(3) for k in range(i)]
        assert min(gaps) > 0.05 * robot_reach(robot), (key, "targets spread over the workspace")


def test_lab_defaults_slow_the_moves_down_to_the_joints_speed_limits():
    from labkit.labs import lab_defaults
    from labkit.motion import joint_trajectory
    from labkit.robot import Robot, joints_from_display

    robot = Robot.load("gantry_ppp")  # 100 mm/s axes: a 2 s move over most of the travel would be too fast
    d = lab_defaults(robot)
    q0, q1 = joints_from_display(robot, d.parameters["move"])
    assert d.parameters["duration"] > 2.0
    for law in ("cubic", "quintic"):
        traj = joint_trajectory(robot, q0, q1, d.parameters["duration"], law=law, dt=0.01)
        assert np.all(np.abs(traj.qd).max(axis=0) <= [lk.max_velocity for lk in robot.links])
        assert np.all(np.abs(traj.qdd).max(axis=0) <= [lk.max_acceleration for lk in robot.links])


def test_new_lab_refuses_a_non_empty_folder_and_rejects_a_missing_robot(tmp_path):
    from labkit.labs import new_lab

    (tmp_path / "lab").mkdir()
    (tmp_path / "lab" / "notes.txt").write_text("mine")
    with pytest.raises(LabkitError, match="not empty"):
        new_lab("arduino_arm_3dof", tmp_path / "lab")
    with pytest.raises(LabkitError):
        new_lab(tmp_path / "no_such_robot.toml", tmp_path / "other")


def test_an_arm_of_ideal_actuators_gets_the_control_lab_when_every_link_has_an_inertia(tmp_path):
    """The PUMA 560 (no servo tables: ideal actuators on sim://, Armstrong/Corke inertias) gets 08_control without its
    servo identification (PID on a joint's dynamics, computed torque, resolved rate); without inertias it is left out."""
    from labkit.labs import new_lab
    from labkit.reports import notebook_parameters

    puma = new_lab("puma560", tmp_path / "puma")
    assert "08_control" in [p.stem for p in puma.notebooks]
    assert not any("08_control" in note for note in puma.notes)
    assert ast.literal_eval(notebook_parameters(puma.folder / "08_control.ipynb")["robot"]) == "robot.toml"
    gantry = new_lab("gantry_ppp", tmp_path / "gantry")
    assert "08_control" not in [p.stem for p in gantry.notebooks]
    assert any(note.startswith("08_control.ipynb: left out, joints without a servo are ideal actuators") and
               "not every link has an inertia" in note for note in gantry.notes)


def test_cli_new_writes_the_lab(tmp_path, capsys, robot_files):
    from labkit.cli import main
    from labkit.reports import notebook_parameters
    from labkit.robot import Robot

    assert main(["new", str(tmp_path / "scara_lab"), "--robot", robot_files["scara"], "--title", "SCARA lab"]) == 0
    out = capsys.readouterr().out
    assert "spatial 3-DOF, prismatic" in out and "labkit render" in out
    lab = tmp_path / "scara_lab"
    # no inertias: no dynamics lab; joints without servos: ideal actuators, no servo dynamics for the control lab
    assert sorted(p.stem for p in lab.glob("*.ipynb")) == [t for t in WITHOUT_INERTIAS if t != "08_control"]
    assert "07_dynamics.ipynb: left out, the robot file has no inertias" in out
    assert "08_control.ipynb: left out, joints without a servo are ideal actuators" in out
    assert (lab / "robot.toml").read_bytes() == open(robot_files["scara"], "rb").read(), "the user's file, unchanged"
    assert not (lab / "robot_with_servos.toml").exists(), "no hobby servos assumed"
    robot = Robot.load(lab / "robot.toml")
    assert "run as ideal actuators on the virtual arm" in out
    assert "shoulder: -120..120 deg (the robot file's limits)" in out and "quill: 20..120 mm" in out
    params = notebook_parameters(lab / "02_fk_check.ipynb")
    assert ast.literal_eval(params["robot"]) == "robot.toml"
    assert ast.literal_eval(params["port"]).startswith("sim://robot.toml?")
    assert len(ast.literal_eval(params["poses"])) == 1 + 2 * robot.n
    nb = json.loads((lab / "01_robot_dh.ipynb").read_text())
    assert nb["cells"][0]["source"][0].startswith("# SCARA lab: 1.")
    assert main(["new", str(lab), "--robot", robot_files["scara"]]) == 2  # not empty


#: a user's robot file as in issue 25 (comments, base +-180 deg, shoulder -117..90 deg)
COMMENTED = """# my OpenMANIPULATOR-X, measured in the lab on 2026-11-30
format = "labkit-robot/1"
name = "my_omx"   # keep this comment
convention = "standard"
units = { length = "mm", angle = "deg" }

[[joint]]
name = "base"
d = 77
alpha = -90
limits = [-180, 180]   # the full turn the servo allows

[[joint]]
name = "shoulder"
a = 130.23
theta = -79.38
limits = [-117, 90]

[[joint]]
name = "elbow"
a = 124
theta = 79.38
limits = [-90, 87]

[[joint]]
name = "wrist"
a = 126
limits = [-100, 117]
"""


@pytest.mark.parametrize("robot", ["openmanipulator_x", "so101", "al5d", "commented"])
def test_new_lab_keeps_the_robot_file_byte_for_byte_and_says_what_it_adds(tmp_path, capsys, robot):
    from labkit.cli import main
    from labkit.reports import notebook_parameters
    from labkit.robot import Robot, bundled_robots

    if robot == "commented":
        source = tmp_path / "my_omx.toml"
        source.write_text(COMMENTED, encoding="utf-8")
    else:
        source = bundled_robots()[robot]
    lab = tmp_path / "lab"
    assert main(["new", str(lab), "--robot", str(source)]) == 0
    out = capsys.readouterr().out
    assert (lab / "robot.toml").read_bytes() == source.read_bytes()
    user = Robot.load(source)
    servos = all(lk.servo is not None or lk.bus is not None for lk in user.links)
    has_inertias = any(lk.inertial is not None for lk in user.links)
    control = servos or all(lk.inertial is not None for lk in user.links)  # servos to identify or dynamics to control
    assert sorted(p.stem for p in lab.glob("*.ipynb")) == [t for t in TEMPLATES if (has_inertias or t != "07_dynamics")
                                                           and (control or t != "08_control")]
    assert ("07_dynamics.ipynb: left out, the robot file has no inertias" in out) == (not has_inertias)
    params = notebook_parameters(lab / "03_ik_check.ipynb")
    if user.bus is not None or all(lk.servo is not None for lk in user.links):  # bus servos or hobby servos: nothing to add
        assert not (lab / "robot_with_servos.toml").exists() and "robot_with_servos" not in out
        assert ast.literal_eval(params["robot"]) == "robot.toml"
        port = ast.literal_eval(params["port"])
        assert port.startswith("sim://robot.toml?") and ("bus=" in port) == (user.bus is not None)
        assert all(len(row) == user.n for row in ast.literal_eval(params["targets"]))  # x y z pitch [roll]
        return
    assert ast.literal_eval(params["robot"]) == "robot.toml" and not (lab / "robot_with_servos.toml").exists()
    assert "robot.toml: your robot file, copied unchanged" in out
    # no hobby-servo window assumed (issue 42): the joints move over the robot file's own limits
    assert "base: -180..180 deg (the robot file's limits)" in out and "narrowed" not in out
    assert "shoulder: -117..90 deg (the robot file's limits)" in out
    # the lab's targets are the kind the arm takes: x y z pitch (4-DOF) or x y z pitch roll (5-DOF)
    width = {4: 4, 5: 5}[user.n]
    assert all(len(row) == width for row in ast.literal_eval(params["targets"]))


@pytest.mark.slow
@pytest.mark.notebooks
def test_eight_labs_scaffold_and_render_with_every_check_passing(tmp_path, robot_files, capsys):
    require("papermill")
    from labkit.labs import new_lab
    from labkit.reports import render
    from labkit.robot import Robot

    labs = [new_lab(robot_files[key], tmp_path / "labs" / key) for key in RENDERED]
    assert [lab.description for lab in labs] == [DESCRIPTIONS[k] for k in RENDERED]
    t0 = time.perf_counter()
    results, wall = render([str(lab.folder) for lab in labs], tmp_path / "reports", jobs=2, pdf=False, progress=None,
                           timeout=300)
    failed = [f"{r.lab}/{r.name}: {r.error}" for r in results if not r.ok]
    assert not failed, "\n".join(failed)

    def expected(lab):  # the dynamics lab needs inertias, the control lab servos (ideal actuators have no servo
        robot = Robot.load(lab.robot_file)  # dynamics) or inertias on every link (the PUMA: computed torque, PID)
        servos = all(lk.servo is not None or lk.bus is not None for lk in robot.links)
        inertias = any(lk.inertial is not None for lk in robot.links)
        control = servos or all(lk.inertial is not None for lk in robot.links)
        return [t for t in TEMPLATES if (inertias or t != "07_dynamics") and (control or t != "08_control")]

    assert [sorted(p.stem for p in lab.notebooks) for lab in labs] == [expected(lab) for lab in labs]
    assert len(results) == sum(len(lab.notebooks) for lab in labs)
    for r in results:
        assert r.html.is_file() and r.notebook.is_file()
        assert (tmp_path / "reports" / r.lab / f"{r.name}_files").is_dir(), "output_dir points into the reports"
    # issue 42's arms (SCARA RRPR, RPP, PPP, planar RP) also make the one hand-in report; the SCARA's IK
    # notebook shows both elbows
    from labkit.cli import main

    for key in ("cobra600_scara", "gantry_ppp", "cylindrical_rpp", "planar_rp"):
        assert main(["report", str(tmp_path / "labs" / key), "--executed", str(tmp_path / "reports" / key),
                     "--to", "html", "-o", str(tmp_path / "book" / key)]) == 0, key
        assert (tmp_path / "book" / f"{key}.html").is_file(), key
    ik_outputs = (tmp_path / "reports" / "cobra600_scara" / "03_ik_check.ipynb").read_text(encoding="utf-8")
    assert "elbow_left" in ik_outputs and "elbow_right" in ik_outputs
    with capsys.disabled():
        print(f"\n{len(RENDERED)} labs, {len(results)} notebooks rendered (--jobs 2, --no-pdf) in {wall:.1f} s "
              f"({time.perf_counter() - t0:.1f} s with the index)")


def test_lab_defaults_leave_a_singular_window_middle_for_a_well_conditioned_home():
    # a UR-like arm whose limits put the window's middle on a singularity (straight up, wrist axes aligned) and
    # none of the home patterns passes the conditioning bar: the best-conditioned pattern is home, not the middle
    from labkit.kinematics import jacobian
    from labkit.labs import lab_defaults
    from labkit.robot import Robot, joints_from_display, servo_window

    robot = Robot.load(FIXTURES / "ur3e_like.toml")
    middle = servo_window(robot).mean(axis=1)
    assert np.linalg.svd(jacobian(robot, middle), compute_uv=False)[-1] < 1e-9  # the middle is singular
    d = lab_defaults(robot)
    home = joints_from_display(robot, d.parameters["home"])
    assert np.linalg.svd(jacobian(robot, home), compute_uv=False)[-1] > 0.02
    assert d.parameters["line_mm"] and d.parameters["arc"]["radius_mm"] > 0


def test_lab_defaults_that_cannot_be_picked_name_the_robot_file_and_why(tmp_path):
    from labkit.labs import lab_defaults

    still = tmp_path / "still.toml"  # every length 0: the tool cannot move
    still.write_text('name = "still"\nconvention = "standard"\n[[joint]]\nlimits = [-1, 1]\n[[joint]]\nlimits = [-1, 1]\n')
    with pytest.raises(LabkitError, match=rf"^{still}: expected an arm with a length .* got every length 0"):
        lab_defaults(still)
    tight = tmp_path / "tight.toml"  # a 1-degree window: no three targets apart
    tight.write_text(YPP4.replace("limits = [-10, 170]", "limits = [40, 41]").replace("[-150, 150]", "[10, 11]"))
    with pytest.raises(LabkitError, match=rf"^{tight}: found no .* inside the joint window \(yaw 10\.\.11 deg, "
                                          rf"shoulder 40\.\.41 deg"):
        lab_defaults(tight)


def test_lab_defaults_pick_poses_within_a_turn_either_side_of_an_endless_joint(tmp_path):
    from labkit.labs import lab_defaults

    endless = tmp_path / "endless.toml"  # a wrist with +-10 turns ("endless"): poses stay within +-1 turn
    endless.write_text(YPP4.replace("limits = [-120, 120]", "limits = [-3600, 3600]"))
    d = lab_defaults(endless)
    wrist = np.array(d.parameters["poses"])[:, 3]
    assert np.all(np.abs(wrist) <= 360) and np.ptp(wrist) >= 0.39 * 720


def test_new_lab_refuses_an_arm_with_more_joints_than_the_board_protocol_carries(tmp_path, capsys):
    from labkit.arm import MAX_JOINTS
    from labkit.cli import main
    from labkit.labs import new_lab

    joints = "".join(f'\n[[joint]]\nname = "j{i}"\na = 100\nlimits = [-150, 150]\n' for i in range(MAX_JOINTS + 2))
    robot = tmp_path / "chain10.toml"
    robot.write_text('format = "labkit-robot/1"\nname = "chain10"\nconvention = "standard"\n'
                     'units = { length = "mm", angle = "deg" }\n' + joints)
    with pytest.raises(LabkitError, match=rf"chain10 .*: {MAX_JOINTS + 2} joints, .* at most {MAX_JOINTS} "):
        new_lab(robot, tmp_path / "lab")
    assert not (tmp_path / "lab").exists(), "no lab folder written"
    assert main(["new", str(tmp_path / "lab"), "--robot", str(robot)]) == 2
    err = capsys.readouterr().err
    assert f"at most {MAX_JOINTS}" in err and "chain10" in err and not (tmp_path / "lab").exists()
