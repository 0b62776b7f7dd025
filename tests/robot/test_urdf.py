"""URDF import (labkit.robot.urdf): FK equal to the URDF's own chain, on packaged and generated files."""

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import require

from labkit.exceptions import RobotError
from labkit.robot import Convention, JointType, Robot


def _urdf_fk(path, robot, q):
    """Tool poses from yourdfpy's own forward kinematics of the same chain."""
    yourdfpy = require("yourdfpy")
    u = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False,
                           build_collision_scene_graph=False, load_collision_meshes=False)
    base, tip = robot.title.split("(")[-1].rstrip(")").split(" -> ")
    out = []
    for qk in np.atleast_2d(q):
        u.update_cfg(dict(zip(robot.joint_names, qk)))
        out.append(u.get_transform(tip, base))
    return np.array(out)


def _packaged_urdfs():
    try:
        import rtbdata
    except ImportError:
        return []
    root = Path(rtbdata.__file__).parent / "xacro"
    return sorted(p for p in root.rglob("*.urdf") if "al5d" not in p.name)


PACKAGED = _packaged_urdfs()


def test_packaged_urdfs_are_found():
    require("rtbdata")  # ships with roboticstoolbox-python (crosscheck extra)
    names = {p.name for p in PACKAGED}
    assert {"lbr_iiwa_14_r820.urdf", "irb140.urdf", "puma560_robot.urdf"} <= names


@pytest.mark.parametrize("path", PACKAGED, ids=lambda p: p.stem)
def test_packaged_urdf_fk_equals_the_urdf_chain(path):
    robot = Robot.from_urdf(path)
    assert robot.convention is Convention.MODIFIED and robot.n >= 6
    lim = robot.joint_limits
    q = np.random.default_rng(1).uniform(lim[:, 0], lim[:, 1], size=(25, robot.n))
    assert np.abs(robot.fk(q) - _urdf_fk(path, robot, q)).max() <= 1e-12


def test_imported_iiwa_and_kr16_keep_names_limits_and_get_closed_form_ik():
    require("rtbdata")
    iiwa = Robot.from_urdf(next(p for p in PACKAGED if p.name == "lbr_iiwa_14_r820.urdf"))
    assert iiwa.n == 7 and iiwa.joint_names[0] == "joint_a1"
    assert iiwa.joint_limits[0].tolist() == [-2.9668, 2.9668]  # as written in the file (170 deg, rounded)
    kr16 = Robot.from_urdf(next(p for p in PACKAGED if p.name == "kr16_2.urdf"))
    from labkit.kinematics import ik_all, solver_for

    assert solver_for(kr16).value == "spherical_wrist"  # shoulder offset, detected from the imported DH table
    q = np.array([0.3, -0.4, 0.5, 0.2, 0.7, -0.1])
    sols = ik_all(kr16, kr16.fk(q))
    assert np.abs(kr16.fk(sols.q[sols.reachable]) - kr16.fk(q)).max() < 1e-9
    assert np.abs(np.remainder(sols.q - q + np.pi, 2 * np.pi) - np.pi).max(axis=1).min() < 1e-9


def test_nearly_parallel_axes_name_the_joint():
    rtbdata = require("rtbdata")
    al5d = next((Path(rtbdata.__file__).parent / "xacro").rglob("al5d_robot.urdf"))
    with pytest.raises(RobotError, match=r"joint 'j3': its axis is 5.9e-10 rad from parallel to the axis of 'j2'"):
        Robot.from_urdf(al5d)
    robot = Robot.from_urdf(al5d, parallel_tol=1e-8)  # accepted as parallel: FK within angle x reach
    q = np.random.default_rng(2).uniform(-1.5, 1.5, size=(10, 4))
    assert np.abs(robot.fk(q) - _urdf_fk(al5d, robot, q)).max() < 1e-8


def _joint(name, parent, child, kind, xyz, rpy, axis, limits=(-2.0, 2.0)):
    lim = "" if kind in ("fixed", "continuous") else \
        f'<limit lower="{float(limits[0])!r}" upper="{float(limits[1])!r}" effort="1" velocity="1.5"/>'
    ax = "" if kind == "fixed" else '<axis xyz="{} {} {}"/>'.format(*(repr(float(v)) for v in axis))
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            '<origin xyz="{} {} {}" rpy="{} {} {}"/>'.format(*(repr(float(v)) for v in [*xyz, *rpy])) + f"{ax}{lim}</joint>")


def _write_chain(path, specs, extra_leaf=False):
    links = [f'<link name="l{i}"/>' for i in range(len(specs) + 1 + extra_leaf)]
    joints = [_joint(f"j{i + 1}", f"l{i}", f"l{i + 1}", *spec) for i, spec in enumerate(specs)]
    if extra_leaf:  # a sensor on l1: the leaf with the most moving joints is still the tip
        joints.append(_joint("sensor", "l1", f"l{len(specs) + 1}", "fixed", (0, 0, 0.1), (0, 0, 0), None))
    path.write_text('<?xml version="1.0"?>\n<robot name="gen">' + "".join(links + joints) + "</robot>")
    return path


def _random_specs(rng, n):
    specs = []
    for _ in range(n):
        kind = rng.choice(["revolute", "revolute", "continuous", "prismatic", "fixed"])
        style = rng.random()
        if style < 0.3:  # axis-aligned: parallel and intersecting axes happen, as in real arms
            rpy = rng.choice([0.0, math.pi / 2, -math.pi / 2, math.pi], size=3)
            axis = np.eye(3)[rng.integers(3)] * rng.choice([1, -1])
            xyz = np.where(rng.random(3) < 0.5, 0.0, rng.uniform(-0.3, 0.3, 3))
        else:
            rpy = rng.uniform(-math.pi, math.pi, 3)
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)  # URDF axes are unit vectors (urdfdom normalises; yourdfpy does not)
            xyz = rng.uniform(-0.3, 0.3, 3)
        specs.append((str(kind), xyz, rpy, axis, (-0.4, 0.5) if kind == "prismatic" else (-2.5, 2.0)))
    return specs


@pytest.mark.parametrize("seed", range(8))
def test_generated_chains_fk_equal_the_urdf_chain(tmp_path, seed):
    rng = np.random.default_rng(100 + seed)
    specs = _random_specs(rng, int(rng.integers(3, 9)))
    if all(s[0] == "fixed" for s in specs):
        specs[0] = ("revolute",) + specs[0][1:]
    path = _write_chain(tmp_path / "gen.urdf", specs, extra_leaf=seed % 2 == 1)
    robot = Robot.from_urdf(path)
    moving = [s for s in specs if s[0] != "fixed"]
    assert robot.n == len(moving)
    assert [lk.joint_type for lk in robot.links] == [
        JointType.PRISMATIC if s[0] == "prismatic" else JointType.REVOLUTE for s in moving]
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(30, robot.n))
    assert np.abs(robot.fk(q) - _urdf_fk(path, robot, q)).max() <= 1e-12


def test_planar_and_wrist_geometry_give_the_textbook_dh_rows(tmp_path):
    """Three parallel z axes 0.3 and 0.2 apart: a = 0.3, 0.2, alpha = 0, like a planar 3R table."""
    specs = [("revolute", (0, 0, 0.1), (0, 0, 0), (0, 0, 1)),
             ("revolute", (0.3, 0, 0), (0, 0, 0), (0, 0, 1)),
             ("revolute", (0.2, 0, 0), (0, 0, 0), (0, 0, 1)),
             ("fixed", (0.05, 0, 0), (0, 0, 0), None)]
    robot = Robot.from_urdf(_write_chain(tmp_path / "planar.urdf", specs))
    assert [round(lk.a, 12) for lk in robot.links] == [0.0, 0.3, 0.2]
    assert all(abs(lk.alpha) < 1e-12 and abs(lk.d) < 1e-12 for lk in robot.links)
    assert robot.base[:3, 3] == pytest.approx([0, 0, 0.1]) and robot.tool[:3, 3] == pytest.approx([0.05, 0, 0])
    from labkit.kinematics import solver_for

    assert solver_for(robot).value == "planar_3r"


def test_saved_import_is_listed_by_labkit_robots(tmp_path, monkeypatch, capsys):
    specs = [("revolute", (0, 0, 0.1), (0, 0, 0), (0, 0, 1)),
             ("revolute", (0, 0, 0.2), (math.pi / 2, 0, 0), (0, 0, 1)),
             ("prismatic", (0.3, 0, 0), (0, 0.3, 0), (1, 0, 0))]
    path = _write_chain(tmp_path / "gen.urdf", specs)
    robot = Robot.from_urdf(path, name="my_import")
    folder = tmp_path / "robots"
    folder.mkdir()
    robot.to_toml(folder / "my_import.toml", length_unit="mm", angle_unit="deg")
    monkeypatch.setenv("LABKIT_ROBOT_PATH", str(folder))
    from labkit.cli import main

    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "my_import" in out and "imported from URDF (l0 -> l3)" in out
    again = Robot.load("my_import")
    q = np.array([[0.3, -0.2, 0.1], [1.0, 0.5, -0.3]])
    assert np.abs(again.fk(q) - robot.fk(q)).max() < 1e-9  # the file keeps 12 significant digits


def test_bad_urdfs_raise_clear_errors(tmp_path):
    ok = [("revolute", (0, 0, 0.1), (0, 0, 0), (0, 0, 1)), ("revolute", (0.3, 0, 0), (0, 0, 0), (0, 1, 0))]
    path = _write_chain(tmp_path / "ok.urdf", ok)
    with pytest.raises(RobotError, match=r"tip_link 'l0' is not below base_link 'l2'"):
        Robot.from_urdf(path, base_link="l2", tip_link="l0")
    with pytest.raises(RobotError, match=r"base_link 'nope' is not a link; expected one of \['l0', 'l1', 'l2'\]"):
        Robot.from_urdf(path, base_link="nope")
    floating = path.read_text().replace('type="revolute"', 'type="floating"', 1)
    (tmp_path / "f.urdf").write_text(floating)
    with pytest.raises(RobotError, match=r"joint 'j1' is 'floating'; expected revolute, continuous, prismatic"):
        Robot.from_urdf(tmp_path / "f.urdf")
    (tmp_path / "z.urdf").write_text(path.read_text().replace('<axis xyz="0.0 0.0 1.0"/>', '<axis xyz="0 0 0"/>', 1))
    with pytest.raises(RobotError, match=r"joint 'j1' has axis \[0.0, 0.0, 0.0\]; expected a non-zero"):
        Robot.from_urdf(tmp_path / "z.urdf")
    (tmp_path / "l.urdf").write_text(path.read_text().replace('lower="-2.5"', 'lower="3.0"', 1)
                                     .replace('lower="-2.0"', 'lower="3.0"', 1))
    with pytest.raises(RobotError, match=r"joint 'j1': expected <limit lower < upper>"):
        Robot.from_urdf(tmp_path / "l.urdf")
    (tmp_path / "bad.urdf").write_text("this is not XML")
    with pytest.raises(RobotError, match="not a readable URDF file"):
        Robot.from_urdf(tmp_path / "bad.urdf")
    (tmp_path / "cut.urdf").write_text("<robot name='x'><link name='a'")  # parsed leniently: one link, no joint
    with pytest.raises(RobotError, match="no revolute or prismatic joint between the links"):
        Robot.from_urdf(tmp_path / "cut.urdf")
    with pytest.raises(RobotError, match="no such URDF file"):
        Robot.from_urdf(tmp_path / "missing.urdf")
