#!/usr/bin/env python3
"""Write the lab notebooks from their source in this script (outputs stay out of git).

    python tools/make_notebooks.py            # (re)write every notebook defined here
    python tools/make_notebooks.py seed002    # only those whose path contains "seed002"

Notebook authors may also reuse the helpers from other scripts::

    from make_notebooks import md, code, parameters, write_notebook

Each notebook: a first markdown cell saying what it reproduces (seed file + section), one
``parameters`` cell (papermill) whose defaults need no hardware, thin code cells that call
labkit, and a last cell with the reproduced-vs-published assertions (:class:`labkit.reports.Checks`).
"""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1] / "notebooks"
SEED002 = "`002_8244010bfe015da6.txt`"


def md(text):
    """A markdown cell (text is dedented)."""
    return nbformat.v4.new_markdown_cell(textwrap.dedent(text).strip("\n"))


def code(text, tags=()):
    """A code cell (text is dedented)."""
    cell = nbformat.v4.new_code_cell(textwrap.dedent(text).strip("\n"))
    if tags:
        cell.metadata["tags"] = list(tags)
    return cell


def parameters(text):
    """The papermill ``parameters`` cell."""
    return code(text, tags=("parameters",))


def write_notebook(path, cells, title=None):
    """Write a clean (output-free) notebook with a python3 kernelspec.

    Cell ids are derived from the file name and the cell's position, so regenerating an
    unchanged notebook leaves git clean.
    """
    nb = nbformat.v4.new_notebook()
    stem = Path(path).stem.replace(".", "-")[:48]
    for k, cell in enumerate(cells):
        cell.id = f"{stem}-{k:02d}"
    nb.cells = cells
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    if title:
        nb.metadata["title"] = title
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.validate(nb)
    nbformat.write(nb, str(path))
    return path


def out_default(lab, name):
    return f'"../../reports/{lab}/{name}_files"'


# --------------------------------------------------------------------------------------------
# seed 002: advanced robotics assignment
# --------------------------------------------------------------------------------------------
LAB002 = "seed002_advanced_robotics"


def seed002_rotations():
    name = "01_rotations"
    return name, "Seed 002, problem 1: rotation matrices and XYZ fixed angles", [
        md(f"""
        # Rotation matrices in any order, XYZ fixed angles both ways

        Reproduces seed {SEED002}, **problem 1**: section 1.1 (rotation matrix of rotations
        about several axes, in a chosen order), section 1.2 (XYZ fixed angles <-> rotation matrix,
        both solutions) and section 1.3 (the MATLAB GUIs, replaced here by ipywidgets; in a
        rendered report the widgets show their initial state).

        Library: `labkit.rotations` (`compose_moving_frame`, `compose_fixed_frame`,
        `matrix_from_euler`, `euler_from_matrix`). Angles are radians in code, degrees in tables.
        """),
        parameters(f"""
        # angles of problem 1(a) [deg]: about x by beta, then about the new y by alpha
        beta_deg = 45.0
        alpha_deg = 30.0
        output_dir = {out_default(LAB002, name)}
        """),
        code("""
        from pathlib import Path

        import numpy as np

        from labkit import rotations as rot
        from labkit.reports import Checks, show_latex

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        checks = Checks("Seed 002 problem 1: reproduced vs published")
        """),
        md("""
        ## 1.1 Rotation matrix of a sequence of rotations

        The seed rotates **about x by 45 deg, then about y by 30 deg** (its `order = [2, 1, 3]`
        input) and prints $R = R_x(\\beta)\\,R_y(\\alpha)$: the second rotation is about the *new*
        (moving) y axis, i.e. post-multiplied. The same matrix results from rotating about the
        *fixed* y first and then about the fixed x (pre-multiplication) - the two readings of a
        rotation sequence.
        """),
        code("""
        R_1a = rot.compose_moving_frame("xy", np.radians([beta_deg, alpha_deg]))
        show_latex(R_1a, prefix="R_x(\\\\beta)\\\\,R_y(\\\\alpha) = ")
        same = np.allclose(R_1a, rot.compose_fixed_frame("yx", np.radians([alpha_deg, beta_deg])))
        print("moving-frame x then y == fixed-frame y then x:", same)
        """),
        md("""
        Any order, any axes: all six orders of the three rotations (x by 45 deg, y by 30 deg, z by 0)
        in the moving frame. With the z angle 0 only the relative order of x and y matters.
        """),
        code("""
        import itertools
        import pandas as pd

        angles = {"x": np.radians(beta_deg), "y": np.radians(alpha_deg), "z": 0.0}
        rows = []
        for order in itertools.permutations("xyz"):
            R = rot.compose_moving_frame(order, [angles[a] for a in order])
            rows.append({"order (moving frame)": "-".join(order), **{f"r{i+1}{j+1}": R[i, j] for i in range(3) for j in range(3)}})
        orders = pd.DataFrame(rows).set_index("order (moving frame)")
        orders.to_csv(out / "rotation_orders.csv")
        orders.round(4)
        """),
        md("""
        ## 1.2 Rotation matrix -> XYZ fixed angles (two solutions)

        $\\beta = \\operatorname{atan2}(-r_{31}, \\pm\\sqrt{r_{11}^2 + r_{21}^2})$,
        $\\alpha = \\operatorname{atan2}(r_{21}/c_\\beta, r_{11}/c_\\beta)$,
        $\\gamma = \\operatorname{atan2}(r_{32}/c_\\beta, r_{33}/c_\\beta)$. The seed's matrix is
        $R_z(30^\\circ)$ rounded to 3 decimals.
        """),
        code("""
        R_1b = np.array([[0.866, -0.5, 0], [0.5, 0.866, 0], [0, 0, 1]])
        sol = rot.euler_from_matrix(R_1b, "xyz_fixed")
        angles_table = pd.DataFrame(np.degrees(sol.solutions), columns=["gamma (x) [deg]", "beta (y) [deg]", "alpha (z) [deg]"],
                                    index=["solution 1", "solution 2"])
        back = rot.matrix_from_euler(sol.solutions, "xyz_fixed")
        angles_table["max |R(angles) - R|"] = np.abs(back - R_1b).max(axis=(-2, -1))
        print("gimbal lock:", bool(sol.gimbal_lock))
        angles_table.round(4)
        """),
        md("""
        ## 1.2 XYZ fixed angles -> rotation matrix

        $R_{XYZ}(\\gamma, \\beta, \\alpha) = R_z(\\alpha) R_y(\\beta) R_x(\\gamma)$ with
        $\\gamma = 45^\\circ$ (x), $\\beta = 30^\\circ$ (y), $\\alpha = 0$ (z). It differs from 1.1
        because the order differs: fixed x then fixed y is $R_y R_x$, not $R_x R_y$.
        """),
        code("""
        R_fixed = rot.matrix_from_euler(np.radians([45.0, 30.0, 0.0]), "xyz_fixed")
        show_latex(R_fixed, prefix="R_{XYZ}(45^\\\\circ, 30^\\\\circ, 0) = ")
        """),
        md("""
        ## 1.3 Interactive version (in place of the MATLAB GUIs)

        Move the sliders and pick the order; the second widget converts XYZ fixed angles to the
        matrix and back (both solutions). In the rendered report the widgets are snapshots at
        their initial values.
        """),
        code("""
        import ipywidgets as widgets

        def _show_sequence(x_deg=45.0, y_deg=30.0, z_deg=0.0, order="x-y-z", frame="moving"):
            axes = order.split("-")
            a = {"x": x_deg, "y": y_deg, "z": z_deg}
            compose = rot.compose_moving_frame if frame == "moving" else rot.compose_fixed_frame
            R = compose(axes, np.radians([a[k] for k in axes]))
            show_latex(R, prefix=f"R_{{{order},\\\\ {frame}}} = ")

        slider = dict(min=-180.0, max=180.0, step=1.0, continuous_update=False)
        widgets.interact(
            _show_sequence,
            x_deg=widgets.FloatSlider(value=45.0, description="x [deg]", **slider),
            y_deg=widgets.FloatSlider(value=30.0, description="y [deg]", **slider),
            z_deg=widgets.FloatSlider(value=0.0, description="z [deg]", **slider),
            order=["-".join(p) for p in itertools.permutations("xyz")],
            frame=["moving", "fixed"],
        );
        """),
        code("""
        def _show_fixed_angles(gamma_deg=45.0, beta_deg=30.0, alpha_deg=0.0):
            R = rot.matrix_from_euler(np.radians([gamma_deg, beta_deg, alpha_deg]), "xyz_fixed")
            show_latex(R, prefix="R = ")
            both = rot.euler_from_matrix(R, "xyz_fixed")
            print("back to (gamma, beta, alpha) [deg]:")
            print(np.round(np.degrees(both.solutions), 3), "(gimbal lock)" if both.gimbal_lock else "")

        widgets.interact(
            _show_fixed_angles,
            gamma_deg=widgets.FloatSlider(value=45.0, description="gamma (x)", **slider),
            beta_deg=widgets.FloatSlider(value=30.0, min=-90.0, max=90.0, step=1.0, description="beta (y)", continuous_update=False),
            alpha_deg=widgets.FloatSlider(value=0.0, description="alpha (z)", **slider),
        );
        """),
        md("""
        ## Checks against the published numbers

        Published matrices have 4 decimals: tolerance 5e-5 (half a unit of the last digit).
        The published second angle solution `[-180 -180 -150]` is the same rotation as labkit's
        `(180, 180, -150)` (angles wrapped to (-180, 180]); it is compared modulo 360 deg.
        """),
        code("""
        checks.check("R, 45 deg about x then 30 deg about y (sec. 1.1)", R_1a,
                     [[0.8660, 0, 0.5000], [0.3536, 0.7071, -0.6124], [-0.3536, 0.7071, 0.6124]], tol=5e-5,
                     note="4 published decimals")
        checks.check("XYZ fixed angles, solution 1 [deg] (sec. 1.2)", np.degrees(sol.first), [0, 0, 30], tol=0.05,
                     note="from a matrix rounded to 3 decimals (0.866 = cos 30.0007 deg)")
        wrapped = (np.degrees(sol.second) - np.array([-180, -180, -150]) + 180) % 360 - 180
        checks.check("XYZ fixed angles, solution 2 [deg] mod 360 (sec. 1.2)", wrapped, [0, 0, 0], tol=0.05,
                     note="published [-180 -180 -150] == (180, 180, -150)")
        checks.check("R_XYZ(45, 30, 0) (sec. 1.2)", R_fixed,
                     [[0.8660, 0.3536, 0.3536], [0, 0.7071, -0.7071], [-0.5000, 0.6124, 0.6124]], tol=5e-5,
                     note="4 published decimals")
        checks.assert_all()
        """),
    ]


def seed002_puma():
    name = "02_puma600_fk_ik"
    return name, "Seed 002, problem 2: PUMA 600 DH, FK and IK (8 solutions)", [
        md(f"""
        # PUMA 600: DH table, forward kinematics, inverse kinematics with all solutions

        Reproduces seed {SEED002}, **problem 2**: section 2.1 (DH table 1 and the kinematic
        equation), section 2.2 (FK at all joints = pi/6 and the IK back to those angles,
        including the two values of theta1), section 2.3 (the number of IK solutions: 2 x 2 x 2 = 8)
        and section 2.4 (the GUI: here a function call per target, plus a 3D plot of all solutions).

        Robot file: `labkit/data/robots/puma600_seed002.toml` (standard DH, l0 = 500, l1 = 500,
        l2 = 400, l3 = 150, l_offset = 200 mm). Library: `labkit.kinematics` (`fk`, `ik_all`,
        `ik_numeric`), `labkit.kinematics.symbolic`, `labkit.plotting`.
        """),
        parameters(f"""
        robot = "puma600_seed002"
        q_deg = [30.0, 30.0, 30.0, 30.0, 30.0, 30.0]  # the seed's test configuration (all pi/6)
        output_dir = {out_default(LAB002, name)}
        """),
        code("""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np

        from labkit.kinematics import fk, ik_all
        from labkit.reports import Checks, show_latex
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 002 problem 2: reproduced vs published")
        arm.dh_table()
        """),
        md("""
        ## 2.1 Link transforms

        $^{i-1}A_i = R_z(\\theta_i) T_z(d_i) T_x(a_i) R_x(\\alpha_i)$. The first three symbolic link
        transforms (lengths in mm); the full product is long, as the seed says, and is evaluated
        numerically below.

        *Published code vs table:* the seed's MATLAB listing marks joint 4 as prismatic
        (`joint(4).type = 1`) although table 1 and the rest of the report treat it as revolute;
        the type only affects their Jacobian code, not FK. labkit uses the table (all revolute).
        """),
        code("""
        from labkit.kinematics.symbolic import link_transforms

        A = link_transforms(arm, q=[f"theta{i}" for i in range(1, 7)], length_unit="mm")
        for i in range(3):
            show_latex(A[i], prefix=f"{{}}^{{{i}}}A_{{{i + 1}}} = ")
        """),
        md("""
        ## 2.2 Forward kinematics at $\\theta_i = \\pi/6$ (positions in mm)
        """),
        code("""
        q = np.radians(q_deg)
        T = fk(arm, q)
        T_mm = T.copy()
        T_mm[:3, 3] *= 1e3
        show_latex(T_mm, prefix="{}^0_6T = ")
        """),
        md("""
        ## 2.2-2.3 Inverse kinematics: every solution

        The wrist centre $W = p - l_3 a$ fixes $\\theta_1$ (two solutions of
        $-s_1 p_{wx} + c_1 p_{wy} = l_{offset}$), then $\\theta_2$ (two) and $\\theta_3$ (one each),
        and the wrist gives two $(\\theta_4, \\theta_5, \\theta_6)$ sets: **8 solutions**.
        `labkit.kinematics.ik_all` returns all of them with branch names; each is checked by FK.
        """),
        code("""
        sols = ik_all(arm, T)
        table = sols.to_dataframe()
        table["FK error [mm]"] = np.linalg.norm(fk(arm, sols.q)[:, :3, 3] - T[:3, 3], axis=-1) * 1e3
        table["orientation error"] = np.abs(fk(arm, sols.q)[:, :3, :3] - T[:3, :3]).max(axis=(-2, -1))
        table.to_csv(out / "puma600_ik_solutions.csv")
        print(f"{sols.reachable.sum()} reachable solutions, {sols.valid.sum()} inside the joint limits")
        table.round(4)
        """),
        code("""
        theta1_values = np.unique(np.round(sols.q[:, 0], 6))
        print("distinct theta1 [rad]:", np.round(theta1_values, 4), "(published: -2.1156 and 0.5236)")
        match = np.all(np.isclose(((sols.q - q + np.pi) % (2 * np.pi)) - np.pi, 0, atol=1e-9), axis=1)
        print("branch that returns the seed's configuration:", [b for b, m in zip(sols.branches, match) if m])
        """),
        md("""
        The seed's *first* method solved the equations numerically (`fsolve` from pi/6 guesses).
        The numeric counterpart, `labkit.kinematics.ik_numeric` (damped least squares), converges to the
        branch nearest its start:
        """),
        code("""
        from labkit.kinematics import ik_numeric

        numeric = ik_numeric(arm, T, q0=np.full(6, 0.4))
        print("numeric IK from q0 = 0.4 rad:", np.round(numeric.q, 6), f"({int(numeric.iterations)} iterations,"
              f" residual {float(numeric.residual):.1e})")
        """),
        md("""
        ## 3D plot of all eight solutions (the seed's figure 3 showed one configuration)
        """),
        code("""
        from labkit.plotting import plot_arm

        fig = plt.figure(figsize=(11, 5.5))
        for k in range(2):
            ax = fig.add_subplot(1, 2, k + 1, projection="3d")
            for j in range(4 * k, 4 * k + 4):
                plot_arm(arm, sols.q[j], ax=ax, dims=3, color=f"C{j}", label=sols.branches[j], orientation_arrow=False)
            ax.set_title("shoulder " + ("right" if k == 0 else "left") + ": 4 solutions")
            ax.legend(fontsize=7, loc="upper left")
        fig.tight_layout()
        plt.show()
        """),
        md("""
        ## 2.4 The GUI, as a function

        `ik_all` on any pose; an unreachable pose reports how far out of reach it is (the seed's
        "out of workspace" status).
        """),
        code("""
        far = T.copy()
        far[:3, 3] = [1.5, 0.0, 0.5]  # 1.5 m away: beyond l1 + l2 + l3
        unreachable = ik_all(arm, far)
        print("reachable solutions:", int(unreachable.reachable.sum()),
              f"- out of workspace by {float(unreachable.distance) * 1e3:.0f} mm")
        """),
        md("""
        ## Checks against the published numbers

        FK: the published $^0_6T$ has 4 decimals (rotation) and 4 decimals in mm (position):
        tolerances 5e-5 and 5e-5 mm. IK: the two published theta1 values (4 decimals), the
        solution count (8), and every solution reproducing the pose to 1e-9.
        """),
        code("""
        published_T = np.array([[0.2522, 0.1044, 0.9620, 719.3029],
                                [-0.7874, -0.5558, 0.2667, 602.9285],
                                [0.5625, -0.8248, -0.0580, 541.2981]])
        checks.check("0_6T rotation (sec. 2.2)", T[:3, :3], published_T[:, :3], tol=5e-5, note="4 published decimals")
        checks.check("0_6T position [mm] (sec. 2.2)", T_mm[:3, 3], published_T[:, 3], tol=5e-5, note="4 published decimals")
        checks.check("theta1 solutions [rad] (sec. 2.2)", theta1_values, [-2.1156, 0.5236], tol=5e-5, note="4 published decimals")
        checks.check("number of IK solutions (sec. 2.3)", sols.reachable.sum(), 8, tol=0, note="2 x 2 x 2")
        checks.check("IK solution returning pi/6 everywhere (sec. 2.2)", match.sum(), 1, tol=0, note="exactly one branch")
        checks.check("FK(IK(T)) error, all 8 [mm]", table["FK error [mm]"].max(), 0.0, tol=1e-9, note="round trip")
        checks.check("numeric IK [rad] (sec. 2.2, first method)", numeric.q, np.full(6, 0.5236), tol=5e-5,
                     note="published 0.5236 (4 decimals)")
        checks.assert_all()
        """),
    ]


def seed002_rpp():
    name = "03_rpp_jacobian_forces"
    return name, "Seed 002, problem 3: RPP Jacobian and joint forces", [
        md(f"""
        # RPP manipulator: Jacobian and the joint forces that balance a tip force

        Reproduces seed {SEED002}, **problem 3**: section 3.1 (Jacobian from DH table 2,
        symbolic), section 3.2 ($\\tau = J^T F$ symbolically and at $\\theta_1 = 0$,
        $d_2 = d_3 = 1$ with $F = [1, 2, 3, 0, 0, 0]$: $\\tau = [2, 3, 1]$) and section 3.3 (the GUI:
        an interactive widget, a snapshot in the report).

        Robot file: `labkit/data/robots/rpp_seed002.toml` (standard DH; $l_1$ does not enter the
        Jacobian). Library: `labkit.kinematics.symbolic`, `labkit.kinematics` (`jacobian`,
        `joint_torques`).
        """),
        parameters(f"""
        robot = "rpp_seed002"
        q = [0.0, 1.0, 1.0]                   # theta1 [rad], d2 [m], d3 [m]
        force = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]  # [f1, f2, f3, n1, n2, n3] [N, N m]
        output_dir = {out_default(LAB002, name)}
        """),
        code("""
        from pathlib import Path

        import numpy as np
        import sympy as sp

        from labkit.kinematics import jacobian, joint_torques, symbolic
        from labkit.reports import Checks, show_latex
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 002 problem 3: reproduced vs published")
        arm.dh_table()
        """),
        md("""
        ## 3.1 Symbolic Jacobian

        Column $i$ is $[b_{i-1};\\ 0]$ for a prismatic and $[b_{i-1} \\times r_{i-1,e};\\ b_{i-1}]$
        for a revolute joint.
        """),
        code("""
        theta1, d2, d3 = symbolic.joint_symbols(arm, ["theta1", "d2", "d3"])
        J_sym = symbolic.geometric_jacobian(arm, q=[theta1, d2, d3])
        show_latex(J_sym, prefix="J = ")
        J_published = sp.Matrix([[-d3 * sp.sin(theta1), 0, sp.cos(theta1)],
                                 [d3 * sp.cos(theta1), 0, sp.sin(theta1)],
                                 [0, 1, 0], [0, 0, 0], [0, 0, 0], [1, 0, 0]])
        print("identical to the published Jacobian:", sp.simplify(J_sym - J_published) == sp.zeros(6, 3))
        """),
        md("""
        ## 3.2 Joint forces $\\tau = J^T F$
        """),
        code("""
        f1, f2, f3, n1, n2, n3 = sp.symbols("f1 f2 f3 n1 n2 n3", real=True)
        tau_sym = sp.simplify(J_sym.T * sp.Matrix([f1, f2, f3, n1, n2, n3]))
        show_latex(tau_sym, prefix="\\\\tau = J^T F = ")
        J = jacobian(arm, q)
        tau = joint_torques(J, force)
        show_latex(np.array(tau), prefix="\\\\tau(\\\\theta_1 = 0, d_2 = d_3 = 1) = ")
        np.savetxt(out / "rpp_joint_forces.csv", tau[None], delimiter=",", header="tau1 [N m],f2 [N],f3 [N]")
        """),
        md("""
        Direct force analysis, as the seed remarks: at $\\theta_1 = 0$ the third (prismatic) axis
        points along $x_0$, so joint 3 carries $f_1 = 1$; joint 2 acts along $z_0$ and carries
        $f_3 = 3$; the base torque is the moment of $f_2 = 2$ about $z_0$ at the lever $d_3 = 1$.

        ## 3.3 Interactive version (in place of the GUI)
        """),
        code("""
        import ipywidgets as widgets

        def _joint_forces(theta1_deg=0.0, d3_m=1.0, f1=1.0, f2=2.0, f3=3.0, n3=0.0):
            t = joint_torques(jacobian(arm, [np.radians(theta1_deg), 1.0, d3_m]), [f1, f2, f3, 0.0, 0.0, n3])
            print(f"tau1 = {t[0]:.4f} N m   f_d2 = {t[1]:.4f} N   f_d3 = {t[2]:.4f} N")

        widgets.interact(_joint_forces, theta1_deg=(-180.0, 180.0, 1.0), d3_m=(0.0, 2.0, 0.05),
                         f1=(-10.0, 10.0, 0.5), f2=(-10.0, 10.0, 0.5), f3=(-10.0, 10.0, 0.5), n3=(-5.0, 5.0, 0.5));
        """),
        md("""
        ## Checks against the published numbers

        The published $\\tau = [2, 3, 1]$ is exact (integers): tolerance 1e-12. The symbolic
        Jacobian and $\\tau(F)$ must equal the published expressions identically.
        """),
        code("""
        tau_published = sp.Matrix([n3 + d3 * f2 * sp.cos(theta1) - d3 * f1 * sp.sin(theta1), f3,
                                   f1 * sp.cos(theta1) + f2 * sp.sin(theta1)])
        checks.check("tau at theta1=0, d2=d3=1 (sec. 3.2)", tau, [2, 3, 1], tol=1e-12, note="exact")
        checks.check("symbolic J - published J (sec. 3.1)", int(sp.simplify(J_sym - J_published) != sp.zeros(6, 3)), 0,
                     tol=0, note="identical expressions")
        checks.check("symbolic tau - published tau (sec. 3.2)", int(sp.simplify(tau_sym - tau_published) != sp.zeros(3, 1)), 0,
                     tol=0, note="identical expressions")
        checks.assert_all()
        """),
    ]


def seed002_wrist():
    name = "04_puma_wrist_circle"
    return name, "Seed 002, problem 4: PUMA wrist Jacobian, wrench, torques, circle", [
        md(f"""
        # PUMA 600 wrist: Jacobian, wrench transform, joint torques, circle-drawing trajectory

        Reproduces seed {SEED002}, **problem 4**: section 4.1 (Jacobian of the three wrist
        joints, DH table 3), section 4.2 (the wrench at the tool point A moved to frame 3 and the
        joint torques; the configuration that draws a circle on the work surface), section 4.3
        (joint angles, rates and torques versus time; circle; arm at several instants) and section
        4.4 (the GUI animation, here a jshtml animation).

        Robot file: `labkit/data/robots/puma_wrist_seed002.toml` (standard DH, lengths in mm in the
        file; the tool transform is row (4) of table 3: point A). Library:
        `labkit.kinematics.symbolic`, `labkit.kinematics` (`fk_frames`, `jacobian`, `joint_torques`,
        `transform_wrench`), `labkit.motion`, `labkit.plotting`.
        """),
        parameters(f"""
        robot = "puma_wrist_seed002"
        force_t = 10.0        # friction force magnitude, against the tool velocity [N]
        force_n = 10.0        # normal force magnitude, along -z0 [N]
        moment_x3 = 0.04e-3   # moment about x3 [N m]; the seed's "0.04" was in N mm (see below)
        duration = 6.283185307179586  # one revolution at 1 rad/s [s]
        output_dir = {out_default(LAB002, name)}
        """),
        code("""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import sympy as sp

        from labkit.kinematics import fk_frames, jacobian, joint_torques, symbolic, transform_wrench
        from labkit.motion import Trajectory
        from labkit.reports import Checks, show_latex
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        wrist = Robot.load(robot)
        checks = Checks("Seed 002 problem 4: reproduced vs published")
        wrist.dh_table()
        """),
        md("""
        ## 4.1 Jacobian

        The seed's Jacobian is that of the **origin of frame 3** (its `cal_Ji(joint, k, 3)` uses
        three frames), in mm; the tool point A is then handled by moving the wrench to frame 3.
        The point in tool coordinates is minus the tool translation (100, 0, 50) mm.
        """),
        code("""
        th = symbolic.joint_symbols(wrist, ["theta1", "theta2", "theta3"])
        o3_in_tool = -wrist.tool[:3, 3]
        J3_sym = symbolic.geometric_jacobian(wrist, point=o3_in_tool, q=th, length_unit="mm")
        show_latex(J3_sym, prefix="J_{O_3} = ")
        s1, c1, s2, c2 = sp.sin(th[0]), sp.cos(th[0]), sp.sin(th[1]), sp.cos(th[1])
        J3_published = sp.Matrix([[-100 * s1 * s2, 100 * c1 * c2, 0], [100 * c1 * s2, 100 * s1 * c2, 0],
                                  [0, -100 * s2, 0], [0, -s1, c1 * s2], [0, c1, s1 * s2], [1, 0, c2]])
        J3_identical = sp.simplify(J3_sym - J3_published) == sp.zeros(6, 3)
        print("identical to the published Jacobian:", J3_identical)
        """),
        md("""
        ## 4.2 The drawing configuration

        The seed assumes link 2 at 45 deg to the vertical: $\\alpha = \\tan^{-1}(100/150)$,
        $\\beta = 45^\\circ - \\alpha$, $c = \\sqrt{100^2 + 150^2}$; the tool point draws a circle of
        radius $a = c \\sin\\beta$ at height $400 + h$, $h = c\\cos\\beta$ (frame 0 coordinates). Its
        fsolve result $(\\theta_1, \\theta_2, \\theta_3) = (-0.5008, -0.6606, 0.3153)$ places A at
        $(0, a, 400 + h)$; rotating $\\theta_1$ alone sweeps the circle (the velocity of A is
        horizontal, parallel to $z_1$).
        """),
        code("""
        c = np.hypot(100.0, 150.0)
        beta = np.pi / 4 - np.arctan(100 / 150)
        radius_mm, height_mm = c * np.sin(beta), 400 + c * np.cos(beta)
        q0 = np.array([-0.5008, -0.6606, 0.3153])  # the seed's initial joint angles [rad]
        frames0 = fk_frames(wrist, q0)
        A0 = frames0[-1][:3, 3] * 1e3
        print(f"circle radius a = {radius_mm:.4f} mm, plane z = {height_mm:.4f} mm")
        print("A at the seed's angles [mm]:", np.round(A0, 4), " target:", np.round([0, radius_mm, height_mm], 4))
        """),
        md("""
        ### Wrench at A, moved to frame 3, and the joint torques

        Friction $f_t = -10\\,z_1$ N (against the velocity), normal $f_N = 10$ N along $-z_0$, and a
        moment $n$ about $x_3$. The wrench at O3 is $[f;\\ n + p_{3A} \\times f]$ and
        $\\tau = J_{O_3}^T F_3$. The same torques follow without the transform from the Jacobian of
        point A itself, $\\tau = J_A^T F_A$ - a consistency check.

        **Units in the seed:** its lengths are mm and it divides $J^T F_3$ by 1000, which makes the
        moment's "0.04" effectively 0.04 N mm = 4e-5 N m. labkit works in SI; `moment_x3` defaults
        to 4e-5 N m to reproduce the published torques (with 0.04 N m they would be
        [0.1930, -0.1573, -0.7604] N m).
        """),
        code("""
        def wrench_at_A(frames):
            z1, x3 = frames[1][:3, 2], frames[3][:3, 0]
            f = force_t * (-z1) + force_n * np.array([0.0, 0.0, -1.0])
            return np.concatenate([f, moment_x3 * x3])

        F_A = wrench_at_A(frames0)
        p_3A = frames0[-1][:3, 3] - frames0[3][:3, 3]
        F_3 = transform_wrench(F_A, p_3A)
        J_O3 = jacobian(wrist, q0, point=o3_in_tool)
        tau0 = joint_torques(J_O3, F_3)
        tau0_direct = joint_torques(jacobian(wrist, q0), F_A)
        print("F_A =", np.round(F_A, 5), " F_3 =", np.round(F_3, 5))
        print("tau = J_O3^T F_3 =", np.round(tau0, 5), "N m;  J_A^T F_A =", np.round(tau0_direct, 5))
        """),
        md("""
        ### Is the tool velocity really parallel to $z_1$?

        The seed argues (figure 7, "surface assumption") that the velocity of A is parallel to $z_1$
        and therefore takes the friction along $-z_1$. Checking it at the seed's own configuration:
        the velocity of A for $\\dot\\theta = [1, 0, 0]$ is $z_0 \\times p_A$, horizontal and
        tangent to the circle, while $z_1$ points elsewhere. With the friction truly opposing the
        velocity the torques change (shown below); the published $M$ is reproduced above with the
        seed's $-z_1$ model.
        """),
        code("""
        z1 = frames0[1][:3, 2]
        v_A0 = (jacobian(wrist, q0) @ [1.0, 0.0, 0.0])[:3]
        angle_v_z1 = np.degrees(np.arccos(abs(z1 @ v_A0) / np.linalg.norm(v_A0)))
        f_physical = force_t * (-v_A0 / np.linalg.norm(v_A0)) + force_n * np.array([0.0, 0.0, -1.0])
        tau_physical = joint_torques(jacobian(wrist, q0), np.concatenate([f_physical, moment_x3 * frames0[3][:3, 0]]))
        print(f"angle between v_A and z1: {angle_v_z1:.1f} deg (the seed assumes 0)")
        print("torques with friction against the velocity [N m]:", np.round(tau_physical, 5))
        """),
        md("""
        ## 4.3 Joint angles, rates and torques versus time

        $\\theta_1 = -0.5008 + t$, $\\theta_2$ and $\\theta_3$ fixed: $\\dot\\theta = [1, 0, 0]$ rad/s.
        The joint rates are recomputed from the tool twist (velocity of A and angular velocity
        $[0, 0, 1]$) with the pseudo-inverse of the Jacobian of A, as the seed did with
        `pinv(J33) * [v3; 0; 0; 1]`. The linear 3x3 block alone is singular here (the seed's
        "entries of inf"), so the angular rows are needed.
        """),
        code("""
        t = np.linspace(0.0, duration, 241)
        q_t = np.column_stack([q0[0] + t, np.full_like(t, q0[1]), np.full_like(t, q0[2])])
        qd_t = np.tile([1.0, 0.0, 0.0], (t.size, 1))
        traj = Trajectory(t=t, q=q_t, qd=qd_t, qdd=np.zeros_like(q_t), joint_names=("theta1", "theta2", "theta3"),
                          revolute=(True, True, True))
        frames_t = fk_frames(wrist, q_t)
        J_A_t = jacobian(wrist, q_t)
        twist_A = np.einsum("...ij,...j->...i", J_A_t, qd_t)  # [v_A; omega]
        qd_from_v = np.einsum("...ij,...j->...i", np.linalg.pinv(J_A_t), twist_A)
        print("rank of the linear block of J_A:", np.linalg.matrix_rank(J_A_t[0, :3, :], tol=1e-9))
        tau_t = joint_torques(J_A_t, np.array([wrench_at_A(f) for f in frames_t]))
        A_t = frames_t[:, -1, :3, 3] * 1e3

        fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True)
        axes[0].plot(t, q_t, label=traj.joint_names)
        axes[0].set_ylabel("joint angle [rad]")
        axes[1].plot(t, qd_from_v, label=traj.joint_names)
        axes[1].set_ylabel("joint rate [rad/s]")
        axes[2].plot(t, tau_t, label=["M1", "M2", "M3"])
        axes[2].set_ylabel("joint torque [N m]")
        axes[2].set_xlabel("t [s]")
        for ax in axes:
            ax.grid(True)
            ax.legend(loc="upper right", fontsize=8)
        fig.suptitle("PUMA wrist drawing a circle (seed figures 8 and 11)")
        fig.tight_layout()
        plt.show()
        traj.to_dataframe().assign(**{f"M{i + 1} [N m]": tau_t[:, i] for i in range(3)}).to_csv(out / "circle_trajectory.csv")
        print("torque range over the circle [N m]:", np.round(tau_t.min(axis=0), 5), "..", np.round(tau_t.max(axis=0), 5))
        """),
        code("""
        from labkit.plotting import plot_arm

        fig = plt.figure(figsize=(11, 4.5))
        ax = fig.add_subplot(1, 2, 1)
        ax.plot(A_t[:, 0], A_t[:, 1])
        ax.plot(*A_t[0, :2], "ro", label="start")
        ax.set_aspect("equal")
        ax.set_xlabel("x0 [mm]"), ax.set_ylabel("y0 [mm]")
        ax.set_title(f"circle on the work surface z = {A_t[:, 2].mean():.2f} mm (fig. 9)")
        ax.legend()
        ax3 = fig.add_subplot(1, 2, 2, projection="3d")
        plot_arm(wrist, q_t[[0, 60, 150]], ax=ax3, dims=3, orientation_arrow=False)
        ax3.plot(A_t[:, 0], A_t[:, 1], A_t[:, 2], "k:", lw=1)
        ax3.set_title("arm at three instants (fig. 10)")
        fig.tight_layout()
        plt.show()
        """),
        md("""
        ## 4.4 Animation (the GUI's drawing simulation)
        """),
        code("""
        from IPython.display import HTML

        from labkit.plotting import animate_arm

        fig = plt.figure(figsize=(5.5, 4.5), dpi=72)
        ax = fig.add_subplot(projection="3d")
        anim = animate_arm(wrist, traj.resample(duration / 36), ax=ax, dims=3, max_frames=37)
        plt.close(fig)  # show the animation only, not its last frame as a static figure
        HTML(anim.to_jshtml())
        """),
        md("""
        ## Checks against the published numbers

        * Jacobian (sec. 4.1): identical expressions.
        * Angles (sec. 4.3) are published with 4 decimals, so A is reproduced to about
          $0.5\\cdot10^{-4}$ rad x 200 mm: tolerance 0.02 mm.
        * Torques $M$ (sec. 4.3): published with 5 significant digits from the rounded angles:
          tolerance 1e-4 N m.
        * **Published inconsistency:** sec. 4.2 prints $\\tau = [0.081598, -0.081563, -0.74319]$ for the
          same configuration, forces and moment as sec. 4.3's $M = [0.16976, -0.16972, -0.76038]$.
          The first set is not reproducible from the stated model (its listing computes $\\tau$ before
          `initial_thetas` is solved); the second is. Recorded as a published typo.
        * **Published modelling error:** the friction is taken along $-z_1$ on the claim that the
          tool velocity is parallel to $z_1$; it is not (angle above). Recorded, with the torques
          for friction opposing the velocity.
        * Rates (sec. 4.3): $[1, 0, 0]$ from the pseudo-inverse.
        """),
        code("""
        checks.check("J_O3 symbolic - published (sec. 4.1)", int(not J3_identical), 0, tol=0, note="identical expressions")
        checks.check("A at the seed's angles [mm] (sec. 4.2)", A0, [0.0, radius_mm, height_mm], tol=0.02,
                     note="angles published to 4 decimals")
        checks.check("circle radius [mm] (sec. 4.3)", np.ptp(np.hypot(A_t[:, 0], A_t[:, 1])), 0.0, tol=1e-9,
                     note="theta1 alone sweeps a circle")
        checks.check("joint torques M [N m] (sec. 4.3)", tau0, [0.16976, -0.16972, -0.76038], tol=1e-4,
                     note="5 significant digits, angles rounded")
        checks.check("tau via J_A^T F_A == via frame 3 [N m]", tau0_direct, tau0, tol=1e-12, note="wrench transform")
        checks.check("joint rates [rad/s] (sec. 4.3)", qd_from_v.mean(axis=0), [1.0, 0.0, 0.0], tol=1e-9, note="pinv(J) v")
        checks.typo("tau (sec. 4.2)", [0.081598, -0.081563, -0.74319], tau0,
                    "same model as sec. 4.3's M; not reproducible - the published M is")
        checks.typo("friction direction: angle(v_A, z1) [deg] (sec. 4.2)", 0.0, angle_v_z1,
                    f"v_A is not parallel to z1; friction against v_A gives tau = {np.round(tau_physical, 4).tolist()} N m")
        checks.assert_all()
        """),
    ]



# --------------------------------------------------------------------------------------------
# servo dynamics (extends seed 000's trajectory section)
# --------------------------------------------------------------------------------------------
LABSERVO = "servo_dynamics"


def servo_tracking():
    name = "01_servo_tracking"
    return name, "Servo dynamics: model, step/Bode, predicted vs measured tracking", [
        md("""
        # Joint servo dynamics: model, step response, Bode plot, tracking of a cubic trajectory

        Extends seed `000_ed0137abc2bf9e33.txt`, **section 8 (trajectory planning with a cubic
        polynomial, run on the Arduino arm)**: the seed commands joint angles every 0.1 s and assumes
        the hobby servos follow ("rough and jagged movement"; "reducing the delay ... can help").
        Here each joint servo is modelled with python-control as a rate-limited second-order
        system, $G(s) = \\omega_n^2 / (s^2 + 2\\zeta\\omega_n s + \\omega_n^2)$, and its predicted
        tracking error for a cubic joint trajectory is set next to the error **measured** on the arm
        (by default the simulated arm `sim://`; pass `-p port /dev/ttyACM0` for a real board).

        The seed publishes no servo numbers: the closing checks compare the model with closed-form
        second-order results and with the measured arm, and the seed's 0.1 s staircase with smooth
        streaming. Library: `control`, `labkit.arm` (`PhysicsConfig`, `ServoBank`, `Arm`), `labkit.motion`.
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        port = "sim://?clock=lockstep&seed=0"  # the simulated arm; a real board: /dev/ttyACM0
        natural_frequency = 25.0  # servo closed-loop natural frequency [rad/s]
        damping_ratio = 0.8       # servo damping ratio [1]
        rate_limit_deg_s = 300.0  # servo speed limit [deg/s]
        q_start_deg = [60.0, 120.0, 100.0]
        q_end_deg = [150.0, 60.0, 140.0]
        duration = 2.0            # cubic trajectory duration [s]
        output_dir = {out_default(LABSERVO, name)}
        """),
        code("""
        from pathlib import Path

        import control
        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.arm import PhysicsConfig, ServoBank
        from labkit.motion import joint_trajectory
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm_model = Robot.load(robot)
        checks = Checks("Servo dynamics: model vs closed form vs measured")
        wn, zeta, rate_limit = natural_frequency, damping_ratio, np.radians(rate_limit_deg_s)
        G = control.tf([wn**2], [1.0, 2 * zeta * wn, wn**2])
        G
        """),
        md("""
        ## Step response and Bode plot

        `control.step_info` gives rise time, overshoot and settling time; for a second-order system
        the overshoot is $e^{-\\pi\\zeta/\\sqrt{1-\\zeta^2}}$ and the peak time
        $\\pi / (\\omega_n\\sqrt{1-\\zeta^2})$.
        """),
        code("""
        info = control.step_info(G)
        pd.Series(info).to_frame("unit step").round(4)
        """),
        code("""
        fig, (ax_step, ax_mag, ax_phase) = plt.subplots(1, 3, figsize=(13, 3.6))
        step = control.step_response(G, T=np.linspace(0, 0.5, 501))
        ax_step.plot(step.time, step.outputs)
        ax_step.set(xlabel="t [s]", ylabel="joint / command", title="unit step response")
        ax_step.grid(True)
        omega = np.logspace(0, 3, 300)
        mag, phase, omega = control.frequency_response(G, omega)
        ax_mag.semilogx(omega, 20 * np.log10(mag))
        ax_mag.set(xlabel="omega [rad/s]", ylabel="|G| [dB]", title="Bode magnitude")
        ax_phase.semilogx(omega, np.degrees(phase))
        ax_phase.set(xlabel="omega [rad/s]", ylabel="phase [deg]", title="Bode phase")
        for ax in (ax_mag, ax_phase):
            ax.grid(True, which="both")
        fig.tight_layout()
        plt.show()
        print(f"bandwidth (-3 dB): {control.bandwidth(G):.2f} rad/s = {control.bandwidth(G) / (2 * np.pi):.2f} Hz")
        """),
        md("""
        ### The rate limit

        A large step is limited by the servo speed: the reference ramps at `rate_limit` and then the
        second-order dynamics follow. `labkit.arm.ServoBank` is the model the virtual arm runs
        (zero-order-hold discretisation of $G$ plus the rate limit; deadband off here).
        """),
        code("""
        config = PhysicsConfig(natural_frequency=wn, damping_ratio=zeta, rate_limit=rate_limit, deadband=0.0)
        bank = ServoBank(arm_model, config, q0=np.radians([0.0, 0.0, 0.0]))
        big_step = np.radians([90.0, 90.0, 90.0])
        bank.command(big_step)
        t_step = np.arange(1, 161) * config.dt
        q_step = np.array([(bank.step(), bank.position.copy())[1] for _ in t_step])
        linear = control.step_response(G, T=t_step).outputs * big_step[0]
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        ax.plot(t_step, np.degrees(q_step[:, 0]), label=f"rate-limited model ({rate_limit_deg_s:.0f} deg/s)")
        ax.plot(t_step, np.degrees(linear), "--", label="linear model, no rate limit")
        ax.set(xlabel="t [s]", ylabel="joint [deg]", title="90 deg step")
        ax.legend()
        ax.grid(True)
        plt.show()
        t90 = t_step[np.argmax(q_step[:, 0] >= 0.9 * big_step[0])]
        print(f"90 % of a 90 deg step after {t90:.3f} s (rate limit alone: {0.9 * big_step[0] / rate_limit:.3f} s)")
        """),
        md("""
        ## Predicted tracking of a cubic joint trajectory

        For a ramp of slope $\\dot q$ the second-order servo lags by $2\\zeta/\\omega_n$ seconds:
        the steady error is $e = -2\\zeta\\dot q/\\omega_n$. A cubic is not a ramp, but it is slow
        compared with the servo, so the predicted error is close to $-2\\zeta\\dot q(t)/\\omega_n$.
        """),
        code("""
        q0, qf = np.radians(q_start_deg), np.radians(q_end_deg)
        traj = joint_trajectory(q0, qf, duration, law="cubic", dt=config.dt)
        t = np.arange(0.0, duration + 0.5, config.dt)
        q_cmd = np.array([np.interp(t, traj.t, traj.q[:, j]) for j in range(arm_model.n)]).T
        qd_cmd = np.array([np.interp(t, traj.t, traj.qd[:, j], right=0.0) for j in range(arm_model.n)]).T
        q_pred = np.column_stack([q0[j] + control.forced_response(G, T=t, U=q_cmd[:, j] - q0[j]).outputs
                                  for j in range(arm_model.n)])
        err_pred = q_pred - q_cmd
        err_ramp = -2 * zeta / wn * qd_cmd
        peak_speed = np.abs(traj.qd).max(axis=0)
        print("peak joint speeds [deg/s]:", np.round(np.degrees(peak_speed), 1), f"(rate limit {rate_limit_deg_s:.0f} deg/s)")
        print("max |predicted error| [deg]:", np.round(np.degrees(np.abs(err_pred).max(axis=0)), 3))
        """),
        md("""
        ## Measured on the arm

        A cubic joint move is a single cubic polynomial, so it goes to the board as **one** `SEG`
        segment; the board runs it while the host records the feedback stream (100 Hz). The
        host-silence timeout is raised for the recording. The board updates the servo pulses every
        20 ms (50 Hz), which adds a small delay: it is estimated by least squares.
        """),
        code("""
        from labkit.arm import Arm

        with Arm(port, robot=robot) as arm:
            arm.move_joints(q0, wait=True)
            arm.sleep(0.3)
            arm.set_host_timeout(duration + 2.0)
            arm.run_trajectory(traj, wait=False, min_duration=duration)
            t_start = arm.status().t
            feedback = arm.stream(duration + 0.5, hz=100)
            arm.set_host_timeout(0.5)
        feedback.to_csv(out / "feedback.csv", index=False)
        t_meas = feedback["t"].to_numpy() - t_start
        q_meas = feedback[[f"q_{n}" for n in arm_model.joint_names]].to_numpy()
        print(f"{len(feedback)} feedback frames, {feedback.attrs['lost']} lost, {feedback.attrs['rejected']} rejected")

        def at(times, series):
            return np.column_stack([np.interp(times, t, series[:, j]) for j in range(series.shape[1])])

        delays = np.arange(0.0, 0.0601, 0.002)
        rms = [np.sqrt(np.mean((q_meas - at(t_meas - d, q_pred)) ** 2)) for d in delays]
        delay = delays[int(np.argmin(rms))]
        rms_best = np.degrees(np.sqrt(np.mean((q_meas - at(t_meas - delay, q_pred)) ** 2, axis=0)))
        err_meas = q_meas - at(t_meas, q_cmd)
        print(f"estimated extra delay: {delay * 1e3:.0f} ms; RMS(measured - predicted) [deg]:", np.round(rms_best, 3))
        """),
        code("""
        fig, axes = plt.subplots(2, arm_model.n, figsize=(13, 5.5), sharex=True)
        for j, name in enumerate(arm_model.joint_names):
            axes[0, j].plot(t, np.degrees(q_cmd[:, j]), "k", lw=1, label="commanded")
            axes[0, j].plot(t, np.degrees(q_pred[:, j]), "--", label="predicted (model)")
            axes[0, j].plot(t_meas, np.degrees(q_meas[:, j]), ".", ms=2.5, label="measured")
            axes[0, j].set_title(name)
            axes[1, j].plot(t, np.degrees(err_pred[:, j]), "--", label="predicted error")
            axes[1, j].plot(t_meas, np.degrees(err_meas[:, j]), ".", ms=2.5, label="measured error")
            axes[1, j].plot(t, np.degrees(err_ramp[:, j]), ":", label="ramp lag -2 zeta qd / wn")
            axes[1, j].set_xlabel("t [s]")
        axes[0, 0].set_ylabel("joint [deg]")
        axes[1, 0].set_ylabel("tracking error [deg]")
        axes[0, 0].legend(fontsize=7)
        axes[1, 0].legend(fontsize=7)
        for ax in axes.flat:
            ax.grid(True)
        fig.tight_layout()
        plt.show()
        """),
        md("""
        ## The seed's staircase (angles written every 0.1 s) versus smooth streaming

        Seed 000 wrote the angle list with a 0.1 s delay between samples. Through the same servo
        model the staircase gives a larger, jagged tracking error - the "rough and jagged movement"
        the seed reports.
        """),
        code("""
        stairs = q_cmd[(np.floor(t / 0.1) * 0.1 / config.dt).round().astype(int).clip(0, len(t) - 1)]
        q_stairs = np.column_stack([q0[j] + control.forced_response(G, T=t, U=stairs[:, j] - q0[j]).outputs
                                    for j in range(arm_model.n)])
        comparison = pd.DataFrame({
            "max |error| smooth [deg]": np.degrees(np.abs(err_pred).max(axis=0)),
            "max |error| 0.1 s staircase [deg]": np.degrees(np.abs(q_stairs - q_cmd).max(axis=0)),
            "max |error| measured [deg]": np.degrees(np.abs(err_meas).max(axis=0)),
        }, index=list(arm_model.joint_names))
        comparison.to_csv(out / "tracking_errors.csv")
        comparison.round(3)
        """),
        md("""
        ## Checks

        * step overshoot and peak time against the closed-form second-order values (1e-3 relative;
          `step_info` works on a sampled response);
        * predicted lag against the ramp formula $2\\zeta\\dot q_{max}/\\omega_n$ (5 % relative: the
          cubic's acceleration adds a little);
        * the cubic stays under the rate limit (otherwise the linear prediction does not apply);
        * measured vs predicted: RMS below 0.5 deg (ADC resolution 0.18 deg/count plus noise and the
          0.45 deg deadband of the simulated servo), extra delay at most two servo frames (40 ms);
        * the staircase is worse than smooth streaming.
        """),
        code("""
        wd = np.sqrt(1 - zeta**2)
        checks.check("step overshoot [%]", info["Overshoot"], 100 * np.exp(-np.pi * zeta / wd), tol=1e-3, relative=True,
                     note="closed form")
        checks.check("step peak time [s]", info["PeakTime"], np.pi / (wn * wd), tol=2e-3, relative=True, note="closed form")
        checks.check("max predicted lag [deg]", np.degrees(np.abs(err_pred).max(axis=0)),
                     np.degrees(2 * zeta / wn * peak_speed), tol=0.05, relative=True, note="ramp lag 2 zeta qd / wn")
        checks.check("peak speed below rate limit", float(np.all(peak_speed < rate_limit)), 1.0, tol=0, note="linear range")
        checks.check("feedback frames received [fraction]", len(feedback) / (100 * (duration + 0.5)), 1.0, tol=0.05,
                     note="100 Hz stream; lost or rejected frames fail here")
        checks.check("RMS measured - predicted [deg]", rms_best, np.zeros(arm_model.n), tol=0.5, note=f"after {delay*1e3:.0f} ms delay")
        checks.check("extra delay [s]", delay, 0.02, tol=0.02, note="servo frames every 20 ms")
        checks.check("staircase worse than smooth", float(np.all(comparison.iloc[:, 1] > comparison.iloc[:, 0])), 1.0, tol=0,
                     note="seed 000 sec. 8.3")
        checks.assert_all()
        """),
    ]


NOTEBOOKS = {
    f"{LAB002}/01_rotations.ipynb": seed002_rotations,
    f"{LAB002}/02_puma600_fk_ik.ipynb": seed002_puma,
    f"{LAB002}/03_rpp_jacobian_forces.ipynb": seed002_rpp,
    f"{LAB002}/04_puma_wrist_circle.ipynb": seed002_wrist,
    f"{LABSERVO}/01_servo_tracking.ipynb": servo_tracking,
}


def main(argv=None, notebooks=None):
    """Write the notebooks of ``notebooks`` ({relative path: builder}, default: this file's)
    whose path contains one of the ``argv`` filters (all if none)."""
    argv = sys.argv[1:] if argv is None else argv
    for rel, make in (NOTEBOOKS if notebooks is None else notebooks).items():
        if argv and not any(a in rel for a in argv):
            continue
        _, title, cells = make()
        print("wrote", write_notebook(ROOT / rel, cells, title=title).relative_to(ROOT.parent))


if __name__ == "__main__":
    main()
