"""The working calls the bad-input sweep starts from: one per public function (tests/test_api_bad_input.py).

Small robots from labkit/data (the 3-joint Arduino arm, the PUMA 560 with its inertias, the OpenManipulator-X
with its bus servos), short trajectories and coarse grids, so that the whole sweep runs in seconds.
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

import labkit.control as control
import labkit.dynamics as dyn
import labkit.kinematics as kin
import labkit.kinematics.symbolic as sym
import labkit.measure as measure
import labkit.motion as motion
import labkit.plotting as plotting
import labkit.robot as robot
import labkit.rotations as rot
import labkit.tables as tables
from labkit.data import measurement_file
from tests.api_sweep import call

R = rot.rotation_z(0.3) @ rot.rotation_x(0.2)
Q3 = np.radians([90.0, 60.0, 100.0])
Q6 = np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0])


@functools.cache
def fixtures():
    arm = robot.Robot.load("arduino_arm_3dof")
    puma = robot.Robot.load("puma560")
    omx = robot.Robot.load("openmanipulator_x")
    traj = motion.joint_trajectory(arm, Q3, Q3 + 0.2, 0.5, dt=0.05)
    ptraj = motion.joint_trajectory(puma, np.zeros(6), np.full(6, 0.1), 0.2, dt=0.05)
    p0 = arm.fk(Q3)[:3, 3]
    path = motion.line_path(p0, p0 + [0.0, 0.02, 0.0])
    ctraj = motion.cartesian_trajectory(arm, path, 0.5, dt=0.1, q_start=Q3)
    fk_log = measure.load_measurements(measurement_file("seed000_fk_tables1-3.csv"))
    published = measure.load_published(measurement_file("seed000_published_calculated.csv"))
    errors = measure.error_table(arm, fk_log)
    tmp = Path(tempfile.mkdtemp(prefix="labkit-sweep-"))
    atexit.register(shutil.rmtree, tmp, True)  # built once per test process, at collection
    return dict(arm=arm, puma=puma, omx=omx, traj=traj, ptraj=ptraj, p0=p0, path=path, ctraj=ctraj,
                fk_log=fk_log, published=published, errors=errors, tmp=tmp)


def _rotations():
    return [
        call("rotation_x", rot.rotation_x, 0.3, kinds="angle:array"),
        call("rotation_y", rot.rotation_y, 0.3, kinds="angle:array"),
        call("rotation_z", rot.rotation_z, [0.3, 0.4], kinds="angle:array"),
        call("rotation_about", rot.rotation_about, "z", 0.3, kinds="axis:option angle:array"),
        call("compose_moving_frame", rot.compose_moving_frame, "zyx", [0.1, 0.2, 0.3],
             kinds="sequence:option angles:array"),
        call("compose_fixed_frame", rot.compose_fixed_frame, "xyz", [0.1, 0.2, 0.3],
             kinds="sequence:option angles:array"),
        call("wrap_angle", rot.wrap_angle, [4.0, -4.0], kinds="angle:array"),
        call("matrix_from_euler", rot.matrix_from_euler, [0.1, 0.2, 0.3], "ZYZ",
             kinds="angles:array convention:option"),
        call("euler_from_matrix", rot.euler_from_matrix, R, "ZYX", kinds="R:array convention:option tol:positive"),
        call("matrix_from_rpy", rot.matrix_from_rpy, [0.1, 0.2, 0.3], kinds="rpy:array"),
        call("rpy_from_matrix", rot.rpy_from_matrix, R, kinds="R:array tol:positive"),
        call("is_rotation", rot.is_rotation, R, kinds="R:array tol:positive"),
        call("check_rotation", rot.check_rotation, R, kinds="R:array tol:positive"),
        call("nearest_rotation", rot.nearest_rotation, R + 0.01, kinds="R:array"),
        call("quaternion_from_matrix", rot.quaternion_from_matrix, R, kinds="R:array tol:positive"),
        call("matrix_from_quaternion", rot.matrix_from_quaternion, [1.0, 0.0, 0.0, 0.0],
             kinds="q:array tol:positive"),
        call("axis_angle_from_matrix", rot.axis_angle_from_matrix, R, kinds="R:array tol:positive"),
        call("matrix_from_axis_angle", rot.matrix_from_axis_angle, [0.0, 0.0, 1.0], 0.3, kinds="axis:array angle:array"),
        call("rotation_vector_from_matrix", rot.rotation_vector_from_matrix, R, kinds="R:array tol:positive"),
        call("matrix_from_rotation_vector", rot.matrix_from_rotation_vector, [0.1, 0.2, 0.3], kinds="v:array"),
        call("skew", rot.skew, [0.1, 0.2, 0.3], kinds="v:array"),
        call("matrix_exp", rot.matrix_exp, rot.skew([0.1, 0.2, 0.3]), kinds="S:array tol:positive"),
        call("matrix_log", rot.matrix_log, R, kinds="R:array tol:positive"),
        call("slerp", rot.slerp, np.eye(3), R, [0.0, 0.5, 1.0], kinds="R_start:array R_end:array s:array tol:positive"),
    ]


def _motion(f):
    arm, traj, path = f["arm"], f["traj"], f["path"]
    law = motion.cubic_law([0.0], [1.0], 1.0)
    P = [[0.15, 0.02, -0.10], [0.20, 0.10, -0.05], [0.10, 0.18, -0.10]]
    return [
        call("cubic_law", motion.cubic_law, 0.0, 1.0, 1.0, v0=0.1,
             kinds="q0:array qf:array duration:positive v0:array vf:array t0:number"),
        call("quintic_law", motion.quintic_law, [0.0, 1.0], [1.0, 0.0], 1.0,
             kinds="q0:array qf:array duration:positive v0:array a0:array af:array t0:number"),
        call("lspb_law", motion.lspb_law, 0.0, 1.0, 2.0, v_max=1.0,
             kinds="q0:array qf:array duration:positive v_max:positive"),
        call("lspb_law blend", motion.lspb_law, 0.0, 1.0, 2.0, blend_time=0.5, kinds="blend_time:positive"),
        call("lspb_law a_max", motion.lspb_law, 0.0, 1.0, 2.0, a_max=2.0, kinds="a_max:positive"),
        call("linear_law", motion.linear_law, 0.0, 1.0, 1.0, kinds="q0:array qf:array duration:positive t0:number"),
        call("make_law", motion.make_law, "quintic", 0.0, 1.0, 1.0, kinds="law:option duration:positive"),
        call("minimum_duration", motion.minimum_duration, 1.0, v_max=1.0, a_max=2.0,
             kinds="distance:array v_max:positive a_max:positive law:option"),
        call("time_grid", motion.time_grid, 0.0, 1.0, 0.1, kinds="t0:number tf:number dt:positive"),
        call("TimeLaw.evaluate", law.evaluate, [0.0, 0.5], 1, kinds="t:array derivative:count"),
        call("TimeLaw.position", law.position, [0.0, 0.5], kinds="t:array"),
        call("TimeLaw.peak", law.peak, 1, 101, kinds="derivative:count samples:count"),
        call("joint_trajectory", motion.joint_trajectory, arm, Q3, Q3 + 0.2, 0.5, dt=0.05,
             kinds="robot:robot q0:array qf:array duration:positive law:option dt:positive"),
        call("joint_trajectory t", motion.joint_trajectory, None, [0.0], [1.0], 1.0, t=[0.0, 0.5, 1.0],
             kinds="t:array"),
        call("law_trajectory", motion.law_trajectory, law, dt=0.1, kinds="law:object dt:positive"),
        call("Trajectory.resample", traj.resample, 0.1, kinds="dt:positive t0:number tf:number"),
        call("Trajectory.to_dataframe", traj.to_dataframe, kinds=""),
        call("via_law", motion.via_law, None, [[0.0], [1.0], [0.5]], [0.0, 1.0, 2.0],
             kinds="points:array times:array law:option ends:option v0:array vf:array"),
        call("via_law durations", motion.via_law, None, [[0.0], [1.0], [0.5]], durations=1.0,
             kinds="durations:positive"),
        call("via_trajectory", motion.via_trajectory, arm, [Q3, Q3 + 0.1, Q3 + 0.2], durations=0.5, dt=0.05,
             kinds="robot:robot points:array durations:positive law:option dt:positive"),
        call("heuristic_velocities", motion.heuristic_velocities, [[0.0], [1.0], [3.0]], [0.0, 1.0, 2.0],
             kinds="points:array times:array v0:array vf:array"),
        call("check_joint_limits", motion.check_joint_limits, arm, traj, kinds="robot:robot traj:object"),
        call("check_speed", motion.check_speed, arm, traj, kinds="robot:robot traj:object tol:positive"),
        call("speed_scale", motion.speed_scale, arm, traj, kinds="robot:robot traj:object"),
        call("line_path", motion.line_path, [0.0, 0.0, 0.0], [0.1, 0.0, 0.0], kinds="start:array end:array"),
        call("arc_path", motion.arc_path, [0.0, 0.0, 0.0], 0.1, 0.0, np.pi,
             kinds="center:array radius:positive start_angle:number sweep:number normal:array"),
        call("circle_path", motion.circle_path, [0.0, 0.0, 0.5], 0.1, kinds="center:array radius:positive"),
        call("waypoint_path", motion.waypoint_path, [[0, 0.2, 0.1], [0.1, 0.2, 0.1], [0.1, 0.2, 0.0]],
             kinds="points:array"),
        call("CartesianPath.point", path.point, [0.0, 0.5], kinds="s:array"),
        call("CartesianPath.distance_from", path.distance_from, f["p0"], kinds="x:array"),
        call("path_law", motion.path_law, path, 2.0, kinds="path:object duration:positive law:option"),
        call("cartesian_trajectory", motion.cartesian_trajectory, arm, path, 0.5, dt=0.1, q_start=Q3,
             kinds="robot:robot path:object duration:positive law:option dt:positive q_start:array "
                   "max_joint_step:positive"),
        call("cartesian_via_trajectory", motion.cartesian_via_trajectory, arm, P, durations=1.0, dt=0.25,
             kinds="robot:robot points:array durations:positive dt:positive law:option ends:option"),
        call("height_above", motion.height_above, arm, [0.1, 0.15, -0.25], reference=[0.1, 0.15, -0.20],
             kinds="robot:robot points:array reference:array"),
        call("approach_point", motion.approach_point, arm, [0.10, 0.15, -0.20], 0.05,
             kinds="robot:robot target:array height:number"),
        call("pick_and_place_legs", motion.pick_and_place_legs, arm, [0, 0.18, -0.094], [0.1, 0.15, -0.2],
             [-0.12, 0.14, -0.16], 0.05, kinds="robot:robot home:array pick:array place:array height:number"),
        call("blended_law", motion.blended_law, None, [[0.0], [1.0], [1.0]], durations=1.0, blend_time=0.5,
             kinds="points:array durations:positive blend_time:positive"),
        call("blended_trajectory", motion.blended_trajectory, None, [[0.0, 0.0], [0.5, 1.0], [1.0, 0.0]],
             v_max=1.0, a_max=4.0, dt=0.05, kinds="points:array v_max:positive a_max:positive dt:positive"),
        call("cartesian_blended_trajectory", motion.cartesian_blended_trajectory, arm, P, v_max=0.1, a_max=0.5,
             dt=0.1, kinds="robot:robot points:array v_max:positive a_max:positive dt:positive"),
    ]


def _kinematics(f):
    arm, puma, omx = f["arm"], f["puma"], f["omx"]
    J = kin.jacobian(arm, Q3)
    p = kin.fk_position(arm, Q3)
    T6 = kin.fk(puma, Q6)
    t4 = kin.target_from_pose(omx, omx.fk([0.1, 0.2, 0.3, 0.4]))
    ws = kin.workspace_points(arm, n=400)
    rq = "robot:robot q:array"
    return [
        call("fk", kin.fk, arm, Q3, kinds=rq),
        call("fk_position", kin.fk_position, arm, Q3, point=[0.0, 0.0, 0.01], kinds=f"{rq} point:array"),
        call("fk_position_with", kin.fk_position_with, arm, Q3, a=[0.0, 0.1, 0.1], base_position=[0.0, 0.0, 0.1],
             kinds=f"{rq} theta:array a:array d:array base_position:array tool_position:array"),
        call("fk_frames", kin.fk_frames, arm, Q3, kinds=rq),
        call("fk_frames_with", kin.fk_frames_with, arm, Q3, d=[0.05, 0.0, 0.0], kinds=f"{rq} d:array"),
        call("jacobian", kin.jacobian, arm, Q3, point=[0.0, 0.0, 0.01], kinds=f"{rq} point:array frame:option"),
        call("fk_jacobian", kin.fk_jacobian, arm, Q3, kinds=f"{rq} point:array frame:option"),
        call("target_kind", kin.target_kind, arm, kinds="robot:robot"),
        call("solver_for", kin.solver_for, arm, kinds="robot:robot"),
        call("ik", kin.ik, arm, p, branch="elbow_up", kinds="robot:robot target:array branch:option solver:option"),
        call("ik q_near", kin.ik, puma, T6, q_near=Q6, kinds="q_near:array"),
        call("ik_all", kin.ik_all, arm, p, kinds="robot:robot target:array solver:option"),
        call("ik_numeric", kin.ik_numeric, arm, p, Q3 + 0.05, mask=[1, 1, 1], restarts=2, seed=1,
             kinds="robot:robot target:array q0:array kind:option mask:array tol:positive max_iter:count "
                   "restarts:count seed:count"),
        call("pose_from_position_pitch", kin.pose_from_position_pitch, omx, t4, kinds="robot:robot target:array"),
        call("task_rows", kin.task_rows, "planar", kinds="kind:option"),
        call("target_components", kin.target_components, "planar", kinds="kind:option"),
        call("joint_torques", kin.joint_torques, J, np.ones(6), kinds="J:array wrench:array"),
        call("wrench_transform_matrix", kin.wrench_transform_matrix, [0.1, 0.0, 0.0], R, kinds="p:array R:array"),
        call("transform_wrench", kin.transform_wrench, np.ones(6), [0.1, 0.0, 0.0], R,
             kinds="wrench:array p:array R:array"),
        call("singular_values", kin.singular_values, J, "linear", kinds="J:array part:option"),
        call("manipulability", kin.manipulability, J, "linear", kinds="J:array part:option"),
        call("condition_number", kin.condition_number, J, "linear", kinds="J:array part:option"),
        call("is_singular", kin.is_singular, J, "linear", kinds="J:array part:option tol:positive"),
        call("damping_factor", kin.damping_factor, 0.005, 0.01, 0.05,
             kinds="sigma_min:array epsilon:positive max_damping:positive"),
        call("joint_rates", kin.joint_rates, J[:3], [0.01, 0.0, 0.0],
             kinds="J:array twist:array epsilon:positive max_damping:positive"),
        call("target_from_display", kin.target_from_display, arm, [100.0, 150.0, -200.0],
             kinds="robot:robot row:array"),
        call("target_to_display", kin.target_to_display, puma, T6, kinds="robot:robot T:array"),
        call("target_error", kin.target_error, arm, Q3, p, kinds="robot:robot q:array target:array"),
        call("target_from_pose", kin.target_from_pose, omx, omx.fk([0.1, 0.2, 0.3, 0.4]), kinds="robot:robot T:array"),
        call("workspace_points", kin.workspace_points, arm, arm.joint_limits, n=50,
             kinds="robot:robot joint_ranges:array n:count seed:count point:array"),
        call("planar_region", kin.planar_region, ws, bins=30, kinds="workspace:object bins:count plane:option "
                                                                     "close_gaps:count"),
        call("symbolic.dh_matrix", sym.dh_matrix, 0.1, 0.0, 0.0, 0.3, kinds="convention:option"),
        call("symbolic.forward_kinematics", sym.forward_kinematics, arm, simplify=False,
             kinds="robot:robot length_unit:option"),
        call("symbolic.geometric_jacobian", sym.geometric_jacobian, arm, simplify=False,
             kinds="robot:robot length_unit:option point:array"),
    ]


def _dynamics(f):
    puma, arm, omx = f["puma"], f["arm"], f["omx"]
    z = np.zeros(6)
    return [
        call("inverse_dynamics", dyn.inverse_dynamics, puma, Q6, z, z, gravity=[0, 0, -9.81],
             kinds="robot:robot q:array qd:array qdd:array gravity:array"),
        call("mass_matrix", dyn.mass_matrix, puma, Q6, kinds="robot:robot q:array"),
        call("coriolis_matrix", dyn.coriolis_matrix, puma, Q6, np.full(6, 0.5), kinds="robot:robot q:array qd:array"),
        call("gravity_torques", dyn.gravity_torques, puma, Q6, kinds="robot:robot q:array gravity:array"),
        call("friction_torques", dyn.friction_torques, puma, [1, 0, 0, 0, 0, -1], kinds="robot:robot qd:array"),
        call("kinetic_energy", dyn.kinetic_energy, puma, Q6, np.full(6, 0.5), kinds="robot:robot q:array qd:array"),
        call("potential_energy", dyn.potential_energy, puma, Q6, kinds="robot:robot q:array gravity:array"),
        call("forward_dynamics", dyn.forward_dynamics, puma, Q6, z, z,
             kinds="robot:robot q:array qd:array tau:array gravity:array"),
        call("simulate", dyn.simulate, puma, Q6, z, [0.0, 0.01], friction=False, rtol=1e-6, atol=1e-8,
             kinds="robot:robot q0:array qd0:array t:array solver:option rtol:positive atol:positive"),
        call("torque_budget", dyn.torque_budget, arm, [0.0, 0.0, 0.0], payload=0.1,
             kinds="robot:robot q:array qd:array qdd:array payload:number payload_com:array gravity:array"),
        call("stall_torques", dyn.stall_torques, arm, kinds="robot:robot"),
        call("torques_from_current", dyn.torques_from_current, omx, [0.0, -0.5, 0.2, 0.1],
             kinds="robot:robot current:array"),
        call("check_torque_budget", dyn.check_torque_budget, arm, f["traj"], payload=0.05,
             kinds="robot:robot trajectory:object payload:number payload_com:array"),
    ]


def _control(f):
    import control as ct

    puma, arm, ptraj = f["puma"], f["arm"], f["ptraj"]
    t = np.linspace(-0.1, 1.0, 111)
    y = control.model_response(t, None, 2, 0.5, 25.0, 0.6, 0.02, 0.1)
    ctl = control.computed_torque_controller(puma, ptraj, 100.0, 20.0)
    return [
        call("fit_step_response", control.fit_step_response, t, y, kinds="t:array y:array u:array order:count"),
        call("model_response", control.model_response, t, None, 2, 2.0, 10.0, 0.5, 0.0, 0.0,
             kinds="t:array order:count gain:number wn:positive zeta:positive delay:number offset:number"),
        call("rate_limited_steps", control.rate_limited_steps, [0.0, 0.05, 0.1, 0.2], 0.0, [(0.0, 1.0)], 10.0,
             kinds="t:array start:number edges:array rate_limit:positive"),
        call("computed_torque_controller", control.computed_torque_controller, puma, ptraj, 100.0, 20.0,
             kinds="model:robot trajectory:object kp:array kd:array gravity:array"),
        call("pd_controller", control.pd_controller, puma, ptraj, 100.0, 20.0,
             kinds="model:robot trajectory:object kp:array kd:array"),
        call("simulate_tracking", control.simulate_tracking, puma, ptraj, ctl, dt=0.05, friction=False,
             kinds="robot:robot trajectory:object controller:object dt:positive solver:option "
                   "rtol:positive atol:positive"),
        call("resolved_rate_trajectory", control.resolved_rate_trajectory, arm, f["path"], 0.5, Q3, dt=0.1,
             kinds="robot:robot path:object duration:positive q0:array law:option gain:positive dt:positive"),
        call("joint_plant", control.joint_plant, puma, Q6, 1, kinds="robot:robot q:array joint:count"),
        call("design_pid", control.design_pid, ct.tf([1.0], [0.01, 0.1, 0.0]), 4.0, kd=0.4,
             kinds="plant:object kp:number ki:number kd:number derivative_filter:positive"),
    ]


def _measure(f):
    arm, tmp = f["arm"], f["tmp"]
    log = measure.MeasurementLog(arm, tmp / "log.csv", session="s1")
    atexit.register(log.close)  # (registered after the folder's removal: runs first)
    names = measure.parameter_names(arm, ("joint_offsets",))
    return [
        call("quantity_dimension", measure.quantity_dimension, "theta2", kinds="quantity:text"),
        call("to_si", measure.to_si, 180.0, "deg", kinds="value:array unit:option"),
        call("parse_numbers", measure.parse_numbers, "0.1 0 -0.05", kinds="text:text"),
        call("MeasurementLog", measure.MeasurementLog, arm, tmp / "log2.csv", session="s1",
             kinds="robot:robot path:object"),
        call("MeasurementLog.record", log.record, "p1", "x", 0.18, unit="m", instrument="ruler", resolution=0.001,
             commanded=Q3, kinds="quantity:option value:number unit:option resolution:positive commanded:array"),
        call("load_measurements", measure.load_measurements, measurement_file("seed000_fk_tables1-3.csv"),
             kinds="path:object"),
        call("joint_sweep_plan", measure.joint_sweep_plan, arm, {1: [45.0, 90.0]}, kinds="robot:robot sweeps:object"),
        call("prompt_reading", measure.prompt_reading, "p1 x", "mm", lo=0, hi=500, input=lambda prompt: "12.5",
             kinds="lo:number hi:number attempts:count"),
        call("decimals_for_resolution", measure.decimals_for_resolution, 0.5, kinds="resolution:positive"),
        call("error_table", measure.error_table, arm, f["fk_log"],
             kinds="robot:robot measurements:object mode:option combine:option"),
        call("fk_error_table", measure.fk_error_table, arm, f["fk_log"], kinds="robot:robot measurements:object"),
        call("ik_error_table", measure.ik_error_table, arm, measurement_file("seed000_ik_table4.csv"),
             branch="elbow_up", kinds="robot:robot measurements:object branch:option"),
        call("ErrorTable.flagged", f["errors"].flagged, 0.01, kinds="tolerance:positive"),
        call("ErrorTable.report_table", f["errors"].report_table, unit="mm", scale=1e3,
             kinds="tolerance:positive unit:option scale:positive pose:option"),
        call("audit_published", measure.audit_published, arm, f["published"], branch="elbow_up",
             kinds="robot:robot published:object branch:option"),
        call("load_published", measure.load_published, measurement_file("seed000_published_calculated.csv"),
             kinds="path:object"),
        call("calibrate", measure.calibrate, arm, f["fk_log"], params=("joint_offsets",), leave_one_out=False,
             kinds="robot:robot measurements:object params:option confidence:positive errors:option"),
        call("parameter_names", measure.parameter_names, arm, ("joint_offsets",), kinds="robot:robot params:option"),
        call("apply_parameters", measure.apply_parameters, arm, names, np.zeros(len(names)),
             kinds="robot:robot names:option values:array"),
        call("predict_positions", measure.predict_positions, arm, [Q3, Q3 + 0.1], kinds="robot:robot q:array"),
    ]


def _plotting(f):
    arm, traj = f["arm"], f["traj"]
    return [
        call("is_planar", plotting.is_planar, arm, Q3, kinds="robot:robot q:array"),
        call("plot_arm", plotting.plot_arm, arm, Q3,
             kinds="robot:robot q:array dims:option units:option frame_length:positive alpha:positive"),
        call("plot_workspace", plotting.plot_workspace, arm, n=200,
             kinds="robot:robot joint_ranges:array n:count style:option dims:option units:option plane:option"),
        call("plot_time_series", plotting.plot_time_series, traj, "qd",
             kinds="traj:object quantity:option units:option"),
        call("plot_trajectory", plotting.plot_trajectory, traj, kinds="traj:object space:option units:option"),
        call("plot_path_3d", plotting.plot_path_3d, f["ctraj"], kinds="path:object units:option"),
        call("animate_arm", plotting.animate_arm, arm, traj, max_frames=3,
             kinds="robot:robot traj:object max_frames:count interval:positive dims:option units:option"),
    ]


def _robot(f):
    arm, omx = f["arm"], f["omx"]
    links = arm.links
    return [
        call("Robot", robot.Robot, "r2", (robot.Link(a=0.1), robot.Link(a=0.1)), base=np.eye(4), tool=np.eye(4),
             up=[0.0, 0.0, 1.0],
             kinds="name:text links:object convention:option base:array tool:array up:array"),
        call("Link", robot.Link, a=0.1, d=0.05, limits=(-1.0, 1.0), max_velocity=2.0,
             kinds="a:number alpha:number d:number theta:number joint_type:option limits:array "
                   "max_velocity:positive max_acceleration:positive"),
        call("ServoCalibration", robot.ServoCalibration, 3, zero=0.1,
             kinds="channel:count zero:number direction:count angle_range:array pulse_range:array "
                   "feedback_adc:array stall_torque:positive no_load_speed:positive"),
        call("Gripper", robot.Gripper, 4, 1000.0, 2000.0, kinds="channel:count open_us:positive closed_us:positive"),
        call("BusServo", robot.BusServo, 11, kinds="id:count zero:number direction:count resolution:count "
                                                   "stall_torque:positive torque_constant:positive"),
        call("Bus", robot.Bus, "dynamixel", kinds="protocol:option baudrate:count resolution:count latency:positive"),
        call("LinkInertia", robot.LinkInertia, 0.5, (0.0, 0.0, 0.1), (0.01, 0.01, 0.01, 0.0, 0.0, 0.0),
             kinds="mass:positive com:array inertia:array"),
        call("LinkInertia.from_matrix", robot.LinkInertia.from_matrix, 0.5, (0.0, 0.0, 0.1), np.eye(3) * 0.01,
             kinds="mass:positive com:array matrix:array"),
        call("Motor", robot.Motor, 1e-5, 50.0, 0.01, kinds="inertia:number gear_ratio:positive viscous:number "
                                                           "coulomb:array"),
        call("Robot.load", robot.Robot.load, "arduino_arm_3dof", kinds="name_or_path:robot"),
        call("Robot.within_limits", arm.within_limits, Q3, kinds="q:array tol:positive"),
        call("Robot.check_limits", arm.check_limits, Q3, kinds="q:array tol:positive"),
        call("Robot.replace", arm.replace, name="other", tool=np.eye(4), kinds="name:text tool:array"),
        call("Robot.with_link", arm.with_link, 1, a=0.12, d=0.0, kinds="index:count a:number d:number"),
        call("Robot.with_payload", arm.with_payload, 0.1, (0.0, 0.0, 0.01), kinds="mass:number com:array"),
        call("Robot.dh_table", arm.dh_table, length_unit="mm", kinds="length_unit:option"),
        call("Robot.to_toml", arm.to_toml, length_unit="mm", angle_unit="deg",
             kinds="length_unit:option angle_unit:option"),
        call("joints_from_display", robot.joints_from_display, arm, [90.0, 60.0, 100.0],
             kinds="robot:robot values:array"),
        call("joints_to_display", robot.joints_to_display, arm, Q3, kinds="robot:robot q:array"),
        call("servo_travel", robot.servo_travel, links[0], kinds="link:object"),
        call("servo_window", robot.servo_window, arm, kinds="robot:robot"),
        call("robot_reach", robot.robot_reach, omx, kinds="robot:robot"),
    ]


def _tables(f):
    df = pd.DataFrame({"q [deg]": [1.0, 2.5], "ok": [True, False]})
    return [
        call("report_table", tables.report_table, df, digits=3, caption="c",
             kinds="df:object digits:count caption:text columns:option"),
        call("ReportTable.mark", tables.report_table(df).mark, [0], [0], kinds="rows:object columns:object css:text"),
        call("error_report_table", tables.error_report_table, f["errors"], unit="mm", scale=1e3,
             kinds="errors:object scale:positive pose:option digits:count flagged:array"),
        call("format_value", tables.format_value, 0.12345, digits=3, unit="m",
             kinds="value:number digits:count decimals:count zero:positive"),
        call("latex_escape", tables.latex_escape, "a_b & 5%", kinds="text:text"),
        call("css_to_latex", tables.css_to_latex, "background-color: #f8c4c4", kinds="css:text"),
    ]


@functools.cache
def all_calls():
    """Every working call of the sweep, by subpackage."""
    f = fixtures()
    return {"rotations": _rotations(), "kinematics": _kinematics(f), "motion": _motion(f), "dynamics": _dynamics(f),
            "control": _control(f),
            "measure": _measure(f), "plotting": _plotting(f), "robot": _robot(f), "tables": _tables(f)}
