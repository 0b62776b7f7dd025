#!/usr/bin/env python3
"""Write the lab notebooks of seeds 000, 003 and 004 from their source in this script.

    python tools/make_notebooks_seed000_003_004.py            # (re)write all of them
    python tools/make_notebooks_seed000_003_004.py seed003    # only paths containing "seed003"

Same conventions as ``tools/make_notebooks.py`` (whose ``md``, ``code``, ``parameters`` and
``write_notebook`` helpers are reused): first markdown cell names the seed file and section, one
papermill ``parameters`` cell with defaults that need no hardware, thin code cells calling labkit,
and a closing :class:`labkit.reports.Checks` cell. Notebooks are written without outputs.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import make_notebooks  # noqa: E402
from make_notebooks import ROOT, code, md, out_default, parameters  # noqa: E402

SEED000 = "`000_ed0137abc2bf9e33.txt`"
SEED003 = "`003_06ee87ab668ce125.txt`"
SEED004 = "`004_bcaca9443077fcb3.txt`"
LAB000 = "seed000_arduino_arm"
LAB003 = "seed003_planar3r"
LAB004 = "seed004_planar3r_ik"
SIM_PORT = '"sim://?clock=lockstep&seed=0"'

# --------------------------------------------------------------------------------------------
# seed 000: 3-DOF Arduino arm (ELEC0129 final report)
# --------------------------------------------------------------------------------------------


def seed000_dh():
    name = "01_link_measurement_dh"
    return name, "Seed 000, II.1-II.3: link measurement, DH parameters, symbolic transforms", [
        md(rf"""
        # Link measurement, DH derivation and the symbolic transforms of the 3-DOF arm

        Reproduces seed {SEED000}, **section II (Forward Kinematics), parts 1-3**: the link
        measurement ($L_1 = 94$ mm, $L_2 = 180$ mm), the modified (Craig) DH table, the three link
        transforms ${{}}^{{i-1}}_iT$, their product ${{}}^0_3T$ and the closed-form end-effector
        position ${{}}^0P$. Every published matrix is compared symbolically with labkit's.

        Robot file: `labkit/data/robots/arduino_arm_3dof.toml` (modified DH; $L_2$ is the tool
        point on $x_3$). Library: `labkit.robot`, `labkit.kinematics.symbolic`, `labkit.kinematics`.
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import numpy as np
        import sympy as sp

        from labkit.kinematics import fk_position, symbolic
        from labkit.reports import Checks, show_latex
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 000 II.1-II.3: reproduced vs published")
        L1_m, L2_m = float(arm.a[2]), float(arm.tool[0, 3])
        print(f"L1 = {L1_m * 1e3:.0f} mm (a_2), L2 = {L2_m * 1e3:.0f} mm (tool point on x3)")
        dh = arm.dh_table()
        dh.to_csv(out / "dh_table.csv")
        dh
        """),
        md(r"""
        ## 1. Link measurement and 3. the DH table

        The seed measured $L_1 = 94$ mm and $L_2 = 180$ mm (mean of three readings). Its DH table
        (rows $a_{i-1}, \alpha_{i-1}, d_i, \theta_i$) is the one above: $\alpha_1 = -90^\circ$,
        $\alpha_2 = 180^\circ$, $a_2 = L_1$, and the gripper point $L_2$ along $x_3$.

        **Discrepancies in the published text (found, not copied):**

        * the text derives $a_1 = L_1 = 94$ mm and $a_2 = L_2 = 180$ mm, but its own table, its
          transforms and its MATLAB code use $a_1 = 0$, $a_2 = L_1$ and put $L_2$ in ${}^3P$ -
          the table is right (the shoulder and elbow axes 1-2 intersect: "the link length from
          Joint 1 to Joint 2 is negligible");
        * $d_i$ is defined as a distance "about" $\bar Z_i$ (it is *along*), $\theta_i$ as a
          "distance" (it is the angle about $\bar Z_i$), and the offsets are listed as
          $d_0, d_1, d_2$ / $\theta_0, \theta_1, \theta_2$ instead of $d_1..d_3$ / $\theta_1..\theta_3$;
        * the MATLAB appendix renames the lengths `L2 = 0.094`, `L3 = 0.18`;
        * ${}^3P$ is first written with a homogeneous coordinate 0 (a direction, which would drop
          the translation), then with 1 (a point) - only the second is right.
        """),
        md(r"""
        ## 2. Drawing steps: the frames on the arm (figures 2.1-2.4)

        The frames the table defines, drawn by `labkit.plotting.plot_arm(..., frames=True)`
        (x red, y green, z blue) at $q = 0$ and at a bent pose: frames 1 and 2 share their origin
        (the axes of joints 1 and 2 intersect), $z_2$ and $z_3$ are parallel and anti-parallel
        ($\alpha_2 = 180^\circ$), and the tool point lies $L_2$ along $x_3$.
        """),
        code(r"""
        import matplotlib.pyplot as plt
        from labkit.plotting import plot_arm

        fig = plt.figure(figsize=(11, 4.8))
        for k, q_deg in enumerate([[0, 0, 0], [30, 45, 60]]):
            ax = fig.add_subplot(1, 2, k + 1, projection="3d")
            plot_arm(arm, np.radians(q_deg), ax=ax, dims=3, frames=True, orientation_arrow=False)
            ax.set_title(f"frames at q = {tuple(q_deg)} deg")
        fig.tight_layout()
        fig.savefig(out / "frames.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## The link transforms ${}^{i-1}_iT = R_x(\alpha_{i-1})\,D_x(a_{i-1})\,R_z(\theta_i)\,D_z(d_i)$

        `labkit.kinematics.symbolic.link_transforms` with the seed's length name $L_1$ (twists are exact
        multiples of $\pi$, so the entries simplify to the published $0, \pm 1$):
        """),
        code(r"""
        q = sp.symbols("theta1:4", real=True)
        L1, L2 = sp.symbols("L1 L2", positive=True)
        A = symbolic.link_transforms(arm, q=list(q), lengths={"L1": L1_m})
        for i, Ai in enumerate(A):
            show_latex(Ai, prefix=f"{{}}^{{{i}}}_{{{i + 1}}}T = ")
        """),
        code(r"""
        c, s = sp.cos, sp.sin
        t1, t2, t3 = q
        published_A = [
            sp.Matrix([[c(t1), -s(t1), 0, 0], [s(t1), c(t1), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
            sp.Matrix([[c(t2), -s(t2), 0, 0], [0, 0, 1, 0], [-s(t2), -c(t2), 0, 0], [0, 0, 0, 1]]),
            sp.Matrix([[c(t3), -s(t3), 0, L1], [-s(t3), -c(t3), 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]),
        ]
        A_diff = [sp.simplify(Ai - Pi) for Ai, Pi in zip(A, published_A)]
        print("labkit - published link transforms == 0:", [d == sp.zeros(4, 4) for d in A_diff])
        """),
        md(r"""
        ## The chain ${}^0_3T = {}^0_1T\,{}^1_2T\,{}^2_3T$ and the end-effector position

        The published product (section II.3) is compared entry by entry; then the gripper point
        ${}^0P = {}^0_3T\,[L_2, 0, 0, 1]^T$ from `labkit.kinematics.symbolic.end_effector_position`.
        """),
        code(r"""
        T03 = sp.simplify(A[0] * A[1] * A[2])
        show_latex(T03, prefix="{}^0_3T = ")
        published_T03 = sp.Matrix([
            [c(t1) * c(t2 - t3), c(t1) * s(t2 - t3), s(t1), L1 * c(t1) * c(t2)],
            [s(t1) * c(t2 - t3), s(t1) * s(t2 - t3), -c(t1), L1 * s(t1) * c(t2)],
            [s(t3 - t2), c(t2 - t3), 0, -L1 * s(t2)],
            [0, 0, 0, 1]])
        T03_identical = sp.simplify(T03 - published_T03) == sp.zeros(4, 4)
        print("labkit 0_3T == published 0_3T:", T03_identical)
        """),
        code(r"""
        P = symbolic.end_effector_position(arm, q=list(q), lengths={"L1": L1_m, "L2": L2_m})
        show_latex(P, prefix="{}^0P = ")
        published_P = sp.Matrix([L2 * c(t1) * c(t2 - t3) + L1 * c(t1) * c(t2),
                                 L2 * s(t1) * c(t2 - t3) + L1 * s(t1) * c(t2),
                                 L2 * s(t3 - t2) - L1 * s(t2)])
        P_identical = sp.simplify(P - published_P) == sp.zeros(3, 1)
        print("labkit 0P == published 0P:", P_identical)
        # the first, homogeneous-0 version of 3P drops the translation of 0_3T:
        P_direction = (published_T03 * sp.Matrix([L2, 0, 0, 0]))[:3, :]
        print("with 3P = [L2, 0, 0, 0]: x =", sp.simplify(P_direction[0]), "(the L1 term is lost)")
        """),
        md(r"""
        ## The closed form against the numeric forward kinematics

        The symbolic position, turned into a numpy function, agrees with the batched numeric FK of
        `labkit.kinematics` on 1000 random configurations; at $q = 0$ the arm is stretched along
        $x_0$: $L_1 + L_2 = 274$ mm.
        """),
        code(r"""
        P_func = sp.lambdify([q, L1, L2], published_P, "numpy")
        rng = np.random.default_rng(0)
        Q = rng.uniform(0, np.pi, size=(1000, 3))
        P_closed = np.stack([np.ravel(P_func(qq, L1_m, L2_m)) for qq in Q])
        P_numeric = fk_position(arm, Q)
        closed_vs_numeric = float(np.abs(P_closed - P_numeric).max())
        print(f"max |closed form - labkit FK| over 1000 configurations: {closed_vs_numeric:.2e} m")
        print("FK at q = 0 [mm]:", np.round(fk_position(arm, [0, 0, 0]) * 1e3, 3))
        """),
        md(r"""
        ## Checks against the published numbers

        Link lengths are published to the millimetre (tolerance 0.5 mm); the transforms and the
        closed-form position must be *identical* expressions (difference simplifies to zero), and
        the closed form must match the numeric FK to 1e-12 m. The published inconsistencies above
        are recorded as typos.
        """),
        code(r"""
        checks.check("L1 [mm] (II.1)", L1_m * 1e3, 94, tol=0.5, note="published to the mm")
        checks.check("L2 [mm] (II.1)", L2_m * 1e3, 180, tol=0.5, note="published to the mm")
        checks.check("link transforms 0_1T, 1_2T, 2_3T - published (II.3)", sum(d != sp.zeros(4, 4) for d in A_diff), 0,
                     tol=0, note="symbolic, identical")
        checks.check("0_3T - published (II.3)", int(not T03_identical), 0, tol=0, note="symbolic, identical")
        checks.check("0P closed form - published (II.3)", int(not P_identical), 0, tol=0, note="symbolic, identical")
        checks.check("closed form vs numeric FK [m]", closed_vs_numeric, 0.0, tol=1e-12, note="1000 random q")
        checks.check("reach at q = 0 [mm]", fk_position(arm, [0, 0, 0])[0] * 1e3, 274, tol=0.5, note="L1 + L2")
        checks.typo("a_1 in the text [mm] (II.3)", 94, 0.0, "text says a_1 = L1; its table/transforms use a_1 = 0, a_2 = L1")
        checks.typo("a_2 in the text [mm] (II.3)", 180, 94, "text says a_2 = L2; L2 is the tool point 3P, a_2 = L1")
        checks.typo("homogeneous coordinate of 3P (II.3)", 0, 1, "3P = [L2 0 0 0] is a direction; the point is [L2 0 0 1]")
        checks.assert_all()
        """),
    ]


def seed000_fk_tables():
    name = "02_fk_check_tables"
    return name, "Seed 000, II.4: FK check tables 1-3, error tables and audit", [
        md(rf"""
        # Checking the forward kinematics: tables 1-3 (calculated vs measured)

        Reproduces seed {SEED000}, **section II.4 "Checking the Calculations"**: one joint at a
        time at five angles (the others at 0), gripper position calculated by FK and measured
        with a ruler (mean ± range of three readings; ruler ± 0.05 cm). Tables 1, 2 and 3 are
        rebuilt with the error tables of `labkit.measure` from the transcribed measurements
        in `labkit/data/measurements/seed000_fk_tables1-3.csv`, the published *calculated* columns are
        audited against the model, and the seed's interpretation is checked against the data.
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        measurements = "seed000_fk_tables1-3.csv"        # file under labkit/data/measurements/ (or a path)
        published = "seed000_published_calculated.csv"  # the report's calculated values
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.data import measurement_file
        from labkit.kinematics import fk_position
        from labkit.measure import audit_published, error_table, load_measurements, load_published
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 000 II.4 tables 1-3: reproduced vs published")

        def data_file(name):
            return Path(name) if Path(name).exists() else measurement_file(name)

        readings = load_measurements(data_file(measurements))
        errors = error_table(readings, arm)
        errors.table.to_csv(out / "fk_error_table.csv", index=False)
        print(f"{readings.pose_id.nunique()} poses, {len(readings)} summary rows (mean ± range of 3 readings each)")
        """),
        md(r"""
        ## Tables 1-3 rebuilt

        For every pose: calculated (labkit FK of the commanded joints), measured mean, its ± range,
        and the error measured - calculated, in metres. A highlighted cell lies **outside** the
        measurement uncertainty $U = \sqrt{\text{resolution}^2 + \text{half range}^2}$.
        """),
        code(r"""
        per_table = {}
        for k, joint in enumerate(["joint 1", "joint 2", "joint 3"], start=1):
            subset = readings[readings.pose_id.str.startswith(f"t{k}_")]
            per_table[k] = error_table(subset, arm)
            display(per_table[k].style().set_caption(f"Table {k}: {joint} varied, the others at 0 deg"))
        """),
        code(r"""
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
        for k, ax in zip(per_table, axes):
            tab = per_table[k].table
            angle = tab.pose_id.str.extract(r"_(\d+)deg")[0].astype(float)
            sweep = np.radians(np.linspace(0, angle.max() + 5, 100))
            q_sweep = np.zeros((sweep.size, 3))
            q_sweep[:, k - 1] = sweep
            model = fk_position(arm, q_sweep) * 1e3
            for j, (qty, color) in enumerate(zip("xyz", ["C0", "C1", "C2"])):
                sel = tab.quantity == qty
                ax.plot(np.degrees(sweep), model[:, j], "-", color=color, label=f"{qty} calculated (FK)")
                ax.errorbar(angle[sel], tab["mean"][sel] * 1e3, yerr=tab.uncertainty[sel] * 1e3, fmt="o",
                            color=color, ms=4, capsize=3, label=f"{qty} measured ± U")
            ax.set(title=f"Table {k}: joint {k}", xlabel=f"joint {k} angle [deg]", ylabel="gripper position [mm]")
            ax.grid(True)
        axes[0].legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(out / "fk_tables.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Summary over the three tables
        """),
        code(r"""
        summary = errors.summary.copy()
        summary[["rms_error", "max_abs_error", "mean_error"]] *= 1e3
        summary = summary.rename(columns={"rms_error": "RMS error [mm]", "max_abs_error": "max |error| [mm]",
                                          "mean_error": "mean error [mm]", "n_inside": "inside U"})
        summary.round(1)
        """),
        md(r"""
        ## Audit of the published "calculated" columns

        `audit_published` recomputes every published calculated value from the robot file and
        flags those that disagree beyond the precision they were printed at ("2 significant
        figures": half a unit of the last printed digit).
        """),
        code(r"""
        published_values = load_published(data_file(published))
        audit = audit_published(published_values[published_values["table"].isin(["table 1", "table 2", "table 3"])], arm)
        flagged = audit.flagged
        display(audit.style())
        flagged
        """),
        md(r"""
        ## Discussion (the seed's interpretation, checked against its data)

        * **Table 1, 5 deg, y**: the seed notes the measured y is 4.1 cm from the calculated one.
          Reproduced below: $0.065 - 0.0239 = 0.041$ m; with its ± 0.05 m range the reading is
          still "inside" its own (very large) uncertainty - a reading, not a model, problem.
        * **Table 2, z**: the seed says the measured z is consistently *smaller* than the calculated
          one because the arm's weight pulls it down. The data show the opposite sign: the
          measured z is consistently **above** the calculated one (less negative, mean error
          printed below). A sag under gravity would put the gripper *below* the model; an offset
          in the zero of joint 2 (the servo horn), or measuring to the top of the gripper, fits
          better. `07_calibration.ipynb` fits joint offsets to these tables.
        * **Table 3, 5 deg**: the published calculated x = 0.24 m equals the *measured* value
          (probably copied into the wrong column); the model gives $L_1 + L_2\cos 5^\circ = 0.2733$ m (the audit
          flags it, together with z = 0.014 vs 0.0157 m and, at 20 deg, z = 0.060 vs 0.0616 m).
          The seed's "slight variations in the accuracy" for joint 3 are partly this typo.
        """),
        code(r"""
        t1 = per_table[1].table.set_index(["pose_id", "quantity"])
        gap_5deg_y = float(t1.loc[("t1_j1_5deg", "y"), "error"])
        t2 = per_table[2].table
        z_err_table2 = t2[t2.quantity == "z"].error.to_numpy()
        print(f"table 1, 5 deg: measured y - calculated y = {gap_5deg_y * 100:.1f} cm")
        print("table 2: measured z - calculated z [mm]:", np.round(z_err_table2 * 1e3, 1))
        """),
        md(r"""
        ## Checks against the published numbers

        * the published calculated values that the audit accepts (within half a unit of the last
          printed digit) - all but three; those three are recorded as published typos;
        * the seed's "4.1 cm" gap (tolerance 0.05 cm, half its last digit);
        * the sign of the table-2 z errors (all positive: measured above the model).
        """),
        code(r"""
        cells = audit.cells
        agree = cells[cells.agrees]
        checks.check("published calculated values within their precision (tables 1-3)", len(agree), 42, tol=0,
                     note="45 values, 3 flagged below")
        checks.check("max |published - recomputed| of the agreeing values [m]", float(np.abs(agree.difference).max()), 0,
                     tol=0.005, note="2 significant figures")
        checks.check("table 1, 5 deg: measured - calculated y [cm]", gap_5deg_y * 100, 4.1, tol=0.05,
                     note="seed: '4.1 cm away from the calculated position'")
        checks.check("table 2: measured z above calculated (count of 5)", int((z_err_table2 > 0).sum()), 5, tol=0,
                     note="the seed claims the opposite")
        for _, row in flagged.iterrows():
            checks.typo(f"{row['table']}, {row.pose_id}, {row.quantity} [m]", float(row.published), row.recomputed,
                        "published calculated value disagrees with the model beyond its printed precision")
        checks.assert_all()
        """),
    ]


def seed000_ik_table4():
    name = "03_ik_table4"
    return name, "Seed 000, III.1-III.4: IK elbow up/down and table 4", [
        md(rf"""
        # Inverse kinematics: elbow up and elbow down, and table 4

        Reproduces seed {SEED000}, **section III (Inverse Kinematics), parts 1-4**: the geometric
        IK (III.1.1-1.3, elbow up), the elbow-down case (III.1.4), and table 4 (calculated vs
        measured joint angles at six targets, protractor ± 0.5 deg).

        Found, not copied: **the seed's elbow-down formula is wrong** (it keeps
        $\theta_3 = 180^\circ - k$; forward kinematics of its angles misses the target by 14-35 cm)
        and **table 4 row 5 is wrong** (published $\theta_1 = -45^\circ$ for target
        $(-0.10, 0.25, -0.01)$, where $\operatorname{{atan2}}(0.25, -0.10) = 111.8^\circ$).
        Library: `labkit.kinematics` (`ik_all`, `fk_position`), `labkit.measure`, `labkit.plotting`.
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        measurements = "seed000_ik_table4.csv"
        published = "seed000_published_calculated.csv"
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.data import measurement_file
        from labkit.kinematics import fk_position, ik_all
        from labkit.measure import audit_published, error_table, load_measurements, load_published
        from labkit.plotting import plot_arm
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 000 III: reproduced vs published")

        def data_file(name):
            return Path(name) if Path(name).exists() else measurement_file(name)

        targets = np.array([[0.10, 0.10, -0.10], [0.15, 0.00, -0.10], [-0.10, 0.10, 0.00],
                            [0.20, 0.10, -0.05], [-0.10, 0.25, -0.01], [-0.08, 0.05, -0.10]])  # table 4 [m]
        """),
        md(r"""
        ## Every IK branch at the six targets

        `ik_all` returns the four closed-form branches of a yaw-pitch-pitch arm (elbow up/down,
        and both "reaching back" over the base with $\theta_1 + 180^\circ$). Only solutions inside
        the servo travel (0-180 deg on every joint) are *valid* on this arm: at every table-4
        target that is the elbow-up branch alone.
        """),
        code(r"""
        sols = ik_all(arm, targets)
        rows = []
        for i, x in enumerate(targets):
            for b, branch in enumerate(sols.branches):
                qd = np.degrees(sols.q[i, b])
                rows.append({"row": i + 1, "target [m]": tuple(x), "branch": branch,
                             "theta1 [deg]": qd[0], "theta2 [deg]": qd[1], "theta3 [deg]": qd[2],
                             "FK error [mm]": 1e3 * np.linalg.norm(fk_position(arm, sols.q[i, b]) - x),
                             "within 0-180 deg": bool(sols.valid[i, b])})
        branches = pd.DataFrame(rows)
        branches.to_csv(out / "ik_all_branches.csv", index=False)
        branches.round(2)
        """),
        md(r"""
        ## III.1.4: the seed's elbow-down formula, tested by forward kinematics

        The seed (and its MATLAB appendix B) computes, with $\alpha = \operatorname{atan2}(-Z, \sqrt{X^2+Y^2})$,
        $\beta$ and $k$ from the cosine rule:

        * elbow up: $\theta_2 = \alpha + \beta$, $\theta_3 = 180^\circ - k$ - correct;
        * elbow down: $\theta_2 = \alpha - \beta$, $\theta_3 = 180^\circ - k$ - **wrong**: mirroring the
          elbow about the shoulder-gripper line also flips the elbow angle, $\theta_3 = k - 180^\circ$.

        The seed's formulas transcribed from appendix B (this is the published formula under
        test, not a solver), then forward kinematics of their angles:
        """),
        code(r"""
        L2_seed, L3_seed = 0.094, 0.180  # appendix B's names for L1, L2
        X, Y, Z = targets.T
        Z = -Z                            # appendix B: "Z = -Z"
        alpha = np.arctan2(Z, np.hypot(X, Y))
        r = np.sqrt(X**2 + Y**2 + Z**2)
        cos_beta = (L2_seed**2 + r**2 - L3_seed**2) / (2 * L2_seed * r)
        beta = np.arctan2(np.sqrt(1 - cos_beta**2), cos_beta)
        cos_k = (L2_seed**2 + L3_seed**2 - r**2) / (2 * L2_seed * L3_seed)
        k = np.arctan2(np.sqrt(1 - cos_k**2), cos_k)
        theta1 = np.arctan2(Y, X)
        seed_up = np.column_stack([theta1, alpha + beta, np.pi - k])
        seed_down = np.column_stack([theta1, alpha - beta, np.pi - k])
        fixed_down = np.column_stack([theta1, alpha - beta, k - np.pi])

        up, down = sols.branches.index("elbow_up"), sols.branches.index("elbow_down")
        miss = lambda q: 1e3 * np.linalg.norm(fk_position(arm, q) - targets, axis=-1)
        elbow = pd.DataFrame({
            "seed elbow up: FK miss [mm]": miss(seed_up),
            "seed elbow down: FK miss [mm]": miss(seed_down),
            "corrected elbow down (theta3 = k - 180): FK miss [mm]": miss(fixed_down),
            "labkit elbow_down theta3 [deg]": np.degrees(sols.q[:, down, 2]),
            "|seed up - labkit elbow_up| [deg]": np.degrees(np.abs(seed_up - sols.q[:, up]).max(axis=1)),
        }, index=pd.RangeIndex(1, 7, name="table 4 row"))
        elbow.round(3)
        """),
        code(r"""
        i = 0  # table 4 row 1
        fig = plt.figure(figsize=(7, 5.5))
        ax = fig.add_subplot(projection="3d")
        plot_arm(arm, sols.q[i, up], ax=ax, dims=3, color="C0", label="elbow up (seed = labkit)", orientation_arrow=False)
        plot_arm(arm, sols.q[i, down], ax=ax, dims=3, color="C2", label="elbow down (labkit)", orientation_arrow=False)
        plot_arm(arm, seed_down[i], ax=ax, dims=3, color="C3", label="seed's elbow-down formula", orientation_arrow=False)
        ax.scatter(*(targets[i] * 1e3), color="k", s=40, marker="x", label="target")
        ax.set_title(f"target {tuple(targets[i].tolist())} m: the seed's elbow down misses by {miss(seed_down)[i]:.0f} mm")
        ax.legend(fontsize=7, loc="upper left")
        fig.savefig(out / "elbow_up_down.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Table 4: calculated vs measured joint angles

        Calculated = labkit elbow-up IK (the branch the seed used on the robot). Highlighted cells
        lie outside the measurement uncertainty (protractor 0.5 deg combined with the ± range).
        """),
        code(r"""
        readings = load_measurements(data_file(measurements))
        table4 = error_table(readings, arm, branch="elbow_up")
        table4.table.to_csv(out / "table4_errors.csv", index=False)
        table4.style().set_caption("Table 4 rebuilt (angles in degrees)")
        """),
        code(r"""
        published_values = load_published(data_file(published))
        audit = audit_published(published_values[published_values["table"] == "table 4"], arm)
        display(audit.style())
        audit.flagged
        """),
        md(r"""
        ## Interpretation

        * Rows 1-4 and 6: the published calculated angles are labkit's elbow-up angles rounded to
          the degree (the text claims "3 significant figures"; they are printed to the degree).
        * **Row 5** is wrong in all three calculated angles: $\theta_1 = -45^\circ$ is not
          $\operatorname{atan2}(0.25, -0.10) = 111.8^\circ$ (and $-45^\circ$ is outside the servo's
          0-180 deg travel); the target is 0.269 m away, close to full stretch (0.274 m), so
          $\theta_2 = 16.7^\circ$, $\theta_3 = 22.1^\circ$, not 105 and 82. The measured
          (30, 110, 85) deg match neither. The photograph caption also gives a different target,
          $(-0.1, 0.25, -0.1)$, which is out of reach (0.287 m).
        * **Row 6** measured $\theta_3 = 49^\circ$ against $131^\circ$ calculated: $180 - 131 = 49$, the
          protractor was read on the other side of the link - the seed says "no anomalies".
        * The caption says "5 different positions"; the table has six rows.
        """),
        code(r"""
        row5 = np.degrees(sols.q[4, up])
        print("row 5 elbow up [deg]:", np.round(row5, 2), f"; distance of target: {np.linalg.norm(targets[4]):.4f} m")
        print("caption target (-0.1, 0.25, -0.1) reachable?", bool(ik_all(arm, [-0.1, 0.25, -0.1]).reachable.any()),
              f"(distance {np.linalg.norm([-0.1, 0.25, -0.1]):.3f} m > reach 0.274 m)")
        """),
        md(r"""
        ## Checks against the published numbers

        Published calculated angles are printed to the degree: tolerance 0.5 deg. The seed's
        elbow-up formula must reproduce labkit's elbow-up solution (1e-9 deg); its elbow-down
        formula must miss (recorded as a published error), and the corrected one must hit (1e-9 m).
        """),
        code(r"""
        published_calc = np.array([[45, 114, 109], [0, 108, 105], [135, 98, 129], [27, 60, 71], [-45, 105, 82], [148, 147, 131]])
        good_rows = [0, 1, 2, 3, 5]
        checks.check("table 4 calculated angles, rows 1-4 and 6 [deg]", np.degrees(sols.q[good_rows, up]),
                     published_calc[good_rows], tol=0.5, note="printed to the degree")
        checks.check("seed elbow-up formula vs labkit elbow_up [deg]", np.degrees(seed_up), np.degrees(sols.q[:, up]),
                     tol=1e-9, note="appendix B, elbow up")
        checks.check("corrected elbow down: FK miss [m]", miss(fixed_down).max() / 1e3, 0.0, tol=1e-9, note="theta3 = k - 180 deg")
        checks.check("labkit elbow_down: FK miss [m]", miss(sols.q[:, down]).max() / 1e3, 0.0, tol=1e-9, note="round trip")
        checks.check("number of valid (0-180 deg) solutions per target", sols.valid.sum(axis=1), np.ones(6), tol=0,
                     note="elbow up only")
        checks.typo("seed elbow-down formula: FK miss [mm] (III.1.4)", miss(seed_down).min(), 0.0,
                    f"theta3 = 180 - k kept; misses by {miss(seed_down).min():.0f}-{miss(seed_down).max():.0f} mm")
        checks.typo("table 4 row 5 theta1 [deg]", -45, row5[0], "atan2(0.25, -0.10) = 111.8 deg")
        checks.typo("table 4 row 5 theta2, theta3 [deg]", [105, 82], row5[1:], "target near full stretch")
        checks.typo("table 4 row 6 measured theta3 [deg]", 49, 180 - 49, "read on the other side of the link: 180 - 49 = 131")
        checks.assert_all()
        """),
    ]


def seed000_linear_motion():
    name = "04_ik_linear_motion"
    return name, "Seed 000, III.5: IK-driven linear motion along x, y, z (potentiometer jog)", [
        md(rf"""
        # IK-driven linear motion along x, y and z on the arm

        Reproduces seed {SEED000}, **section III.5 "Coding the robot to move with inverse
        kinematics"**: a potentiometer sets one coordinate of the gripper while the other two
        stay fixed; inverse kinematics turns every pot reading into joint angles, so the gripper
        moves along a line parallel to x, y or z (the seed shows this in three videos).

        Here the arm is the built-in simulated arm (`port = "sim://..."`): its user potentiometer
        (ADC channel A5, read by `READ`) is turned by the notebook in steps; on a real board
        (`-p port /dev/ttyACM0`) turn the knob while the loop samples it. Every step goes
        through `labkit.arm.Arm.move_to` (IK on the elbow-up branch, limits checked before
        anything moves); the gripper position is then measured from the joint feedback.
        An ipywidgets slider stands in for the knob at the end (a snapshot in reports).
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        port = {SIM_PORT}  # the simulated arm; a real board: /dev/ttyACM0
        centre = [0.0, 0.18, -0.094]  # gripper position the lines go through [m] (the seed's start point)
        half_span = 0.05              # each line runs centre +- half_span along its axis [m]
        pot_steps = 9                 # pot readings per axis
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.arm import Arm
        from labkit.kinematics import fk_position
        from labkit.plotting import plot_arm
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        model = Robot.load(robot)
        checks = Checks("Seed 000 III.5: linear motion on the arm")
        centre = np.asarray(centre, dtype=float)
        ADC_MAX = 1023  # 10-bit Arduino ADC


        def pot_to_offset(counts):
            "The seed's mapping: the pot's travel spans the line, mid-travel is the centre [m]."
            return (counts / ADC_MAX - 0.5) * 2 * half_span


        def read_pot(arm, simulated_counts):
            "Pot reading [counts]; on the simulated arm the notebook turns the knob to simulated_counts."
            board = getattr(arm.port, "board", None)
            if board is not None:
                board.user_pot = int(simulated_counts)
            else:
                arm.sleep(0.3)  # a real board: the student turns the knob between samples
            return int(arm.read_adc()[-1])
        """),
        md(r"""
        ## The jog: one line per axis
        """),
        code(r"""
        arm = Arm(port, robot=robot)
        arm.move_to(centre, branch="elbow_up", wait=True)
        rows = []
        for axis_index, axis in enumerate("xyz"):
            for counts_cmd in np.linspace(0, ADC_MAX, pot_steps).round():
                counts = read_pot(arm, counts_cmd)
                target = centre.copy()
                target[axis_index] += pot_to_offset(counts)
                q_cmd = arm.move_to(target, branch="elbow_up", wait=True)
                q_meas = arm.read_joints()
                rows.append({"axis": axis, "pot [counts]": counts, **{f"target {a} [mm]": v * 1e3 for a, v in zip("xyz", target)},
                             **{f"q{j + 1} cmd [deg]": v for j, v in enumerate(np.degrees(q_cmd))},
                             **{f"q{j + 1} meas [deg]": v for j, v in enumerate(np.degrees(q_meas))},
                             **{f"commanded {a} [mm]": v * 1e3 for a, v in zip("xyz", fk_position(model, q_cmd))},
                             **{f"measured {a} [mm]": v * 1e3 for a, v in zip("xyz", fk_position(model, q_meas))}})
        arm.move_to(centre, branch="elbow_up", wait=True)
        jog = pd.DataFrame(rows)
        jog.to_csv(out / "linear_jog.csv", index=False)
        jog.iloc[::max(1, pot_steps // 3)].round(1)
        """),
        md(r"""
        ## How straight are the lines?

        For each line: the error of the *commanded* gripper position (FK of the IK solution - exact
        up to the servo command resolution of 0.01 deg) and of the *measured* one (FK of the joint
        feedback, which carries the servos' zero offsets, deadband and the pots' ADC resolution)
        from the target, split into along-axis and off-axis parts.
        """),
        code(r"""
        target_xyz = jog[[f"target {a} [mm]" for a in "xyz"]].to_numpy()
        cmd_xyz = jog[[f"commanded {a} [mm]" for a in "xyz"]].to_numpy()
        meas_xyz = jog[[f"measured {a} [mm]" for a in "xyz"]].to_numpy()
        axis_idx = jog.axis.map({"x": 0, "y": 1, "z": 2}).to_numpy()
        along = np.eye(3)[axis_idx]

        def off_axis(points):
            d = points - target_xyz
            return np.linalg.norm(d - (d * along).sum(axis=1, keepdims=True) * along, axis=1)

        straightness = pd.DataFrame({
            "commanded: max |error| [mm]": pd.Series(np.linalg.norm(cmd_xyz - target_xyz, axis=1)).groupby(jog.axis).max(),
            "measured: max off-axis [mm]": pd.Series(off_axis(meas_xyz)).groupby(jog.axis).max(),
            "measured: max |error| [mm]": pd.Series(np.linalg.norm(meas_xyz - target_xyz, axis=1)).groupby(jog.axis).max(),
            "joint travel q1/q2/q3 [deg]": jog.groupby("axis")[[f"q{j} cmd [deg]" for j in (1, 2, 3)]].agg(np.ptp).round(1).astype(str).agg("/".join, axis=1),
        })
        straightness.round(2)
        """),
        code(r"""
        fig = plt.figure(figsize=(12, 4.8))
        ax3 = fig.add_subplot(1, 2, 1, projection="3d")
        for axis, color in zip("xyz", ["C0", "C1", "C2"]):
            sel = (jog.axis == axis).to_numpy()
            ax3.plot(*target_xyz[sel].T, "-", color=color, lw=1, label=f"{axis} line (target)")
            ax3.plot(*meas_xyz[sel].T, "o", color=color, ms=3, label=f"{axis} measured")
        plot_arm(model, np.radians(jog.loc[0, ["q1 cmd [deg]", "q2 cmd [deg]", "q3 cmd [deg]"]].to_numpy(dtype=float)),
                 ax=ax3, dims=3, color="0.5", orientation_arrow=False)
        ax3.set_title("the three jog lines and the measured gripper")
        ax3.legend(fontsize=7, loc="upper left")
        ax = fig.add_subplot(1, 2, 2)
        for axis, color in zip("xyz", ["C0", "C1", "C2"]):
            sel = (jog.axis == axis).to_numpy()
            ax.plot(jog["pot [counts]"][sel], off_axis(meas_xyz)[sel], "o-", color=color, ms=3, label=f"{axis} line")
        ax.set(xlabel="pot [ADC counts]", ylabel="off-axis error, measured [mm]", title="straightness (from joint feedback)")
        ax.grid(True)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "linear_jog.png", dpi=110)
        plt.show()
        """),
        md(r"""
        The seed calls its motion "rough and jagged": its loop wrote each new set of angles at
        once, so every pot change was a step. Here each step is a `MOVE` that the board ramps at
        the servo speed; `seed000_arduino_arm/05_cubic_trajectory.ipynb` and
        `06_pick_and_place.ipynb` go further with cubic Cartesian trajectories.

        ## The knob as a widget

        Live in Jupyter: drag the slider to jog the (simulated or real) arm. In a rendered report
        the widget is shown at its initial value.
        """),
        code(r"""
        import ipywidgets as widgets

        def _jog(axis="x", pot=512):
            target = centre.copy()
            target["xyz".index(axis)] += pot_to_offset(pot)
            try:
                q = arm.move_to(target, branch="elbow_up", wait=True)
                print(f"target {np.round(target * 1e3, 1)} mm -> joints {np.round(np.degrees(q), 2)} deg")
            except Exception as exc:  # unreachable / outside the servo travel: nothing moved
                print(f"not moved: {exc}")

        widgets.interact(_jog, axis=["x", "y", "z"],
                         pot=widgets.IntSlider(value=512, min=0, max=ADC_MAX, step=1, description="pot", continuous_update=False));
        """),
        md(r"""
        ## Checks

        The seed publishes no numbers for this section (videos only). Checked instead:
        * the pot readings reproduce the commanded knob positions exactly on the simulated arm (on
          a real board this check is skipped: the knob is the student's);
        * commanded positions lie on the lines to within 0.2 mm (servo commands are quantised to
          0.01 deg: 0.05 mm at 274 mm, plus the move's settling tolerance);
        * measured positions lie within 10 mm of the lines: the simulated servos have random
          zero offsets (standard deviation 1 deg, about 5 mm at the gripper), deadband and feedback
          noise, like real hobby servos.
        """),
        code(r"""
        simulated = getattr(arm.port, "board", None) is not None
        arm.close()
        if simulated:
            expected_counts = np.tile(np.linspace(0, ADC_MAX, pot_steps).round(), 3)
            checks.check("pot readings [counts]", jog["pot [counts]"].to_numpy(), expected_counts, tol=0, note="simulated knob")
        checks.check("commanded position on the line [mm]", np.linalg.norm(cmd_xyz - target_xyz, axis=1).max(), 0.0, tol=0.2,
                     note="IK + 0.01 deg command resolution")
        checks.check("measured off-axis error [mm]", off_axis(meas_xyz).max(), 0.0, tol=10.0,
                     note="servo zero offsets ~1 deg, deadband, noise")
        checks.check("line length per axis [mm]", np.ptp(target_xyz[np.arange(len(jog)), axis_idx].reshape(3, -1), axis=1),
                     [2 * half_span * 1e3] * 3, tol=1e-9, note="full pot travel")
        checks.assert_all()
        """),
    ]


def seed000_cubic():
    name = "05_cubic_trajectory"
    return name, "Seed 000, IV.1-IV.2: cubic Cartesian trajectory (3-D path, displacement/velocity/acceleration)", [
        md(rf"""
        # Cubic Cartesian trajectory: 3-D path, displacement, velocity and acceleration

        Reproduces seed {SEED000}, **section IV.1-IV.2 (Trajectory Planning: workflow and
        analysis of the time graphs)**: each coordinate follows the rest-to-rest cubic
        $u(t) = u_0 + \frac{{3}}{{t_f^2}}(u_f - u_0)t^2 - \frac{{2}}{{t_f^3}}(u_f - u_0)t^3$ from
        $u_0 = (0, 0.18, -0.094)$ m to $u_f = (0.10, 0.15, -0.20)$ m in $t_f = 5$ s, sampled every
        0.1 s (figures 8.1-8.4), and IK gives the joint angles at every sample (section IV.3).

        Library: `labkit.motion` (`cubic`, `line`, `cartesian_trajectory`), `labkit.plotting`.
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        start = [0.0, 0.18, -0.094]  # u_0 [m]
        end = [0.10, 0.15, -0.20]    # u_f [m]
        duration = 5.0               # t_f [s]
        dt = 0.1                     # sample step [s] (the seed's 0:0.1:5)
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.motion import cartesian_trajectory, cubic, line
        from labkit.plotting import plot_arm, plot_path_3d, plot_time_series
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 000 IV: reproduced vs published")
        u0, uf = np.asarray(start, float), np.asarray(end, float)
        """),
        md(r"""
        ## The cubic coefficients per axis

        $a_0 = u_0$, $a_1 = 0$, $a_2 = 3(u_f - u_0)/t_f^2$, $a_3 = -2(u_f - u_0)/t_f^3$:
        """),
        code(r"""
        law = cubic(u0, uf, duration)
        coefficients = law.coefficient_table(["x [m]", "y [m]", "z [m]"])
        coefficients.to_csv(out / "cubic_coefficients.csv")
        coefficients
        """),
        md(r"""
        ## The trajectory, with IK at every sample

        A cubic time law on the straight line gives exactly the seed's per-axis cubics.
        """),
        code(r"""
        traj = cartesian_trajectory(arm, line(u0, uf), duration, dt=dt, branch="elbow_up")
        speed = np.linalg.norm(traj.xd, axis=1)
        direction = (uf - u0) / np.linalg.norm(uf - u0)
        accel_along = traj.xdd @ direction          # signed acceleration along the path [m/s^2]
        per_axis = np.abs(traj.x - law.position(traj.t)).max()
        print(f"{len(traj.t)} samples; max |line path - per-axis cubics| = {per_axis:.1e} m")
        print(f"peak speed {speed.max():.5f} m/s at t = {traj.t[np.argmax(speed)]:.2f} s")
        traj.to_dataframe(degrees=True).iloc[::10].round(4)
        """),
        code(r"""
        fig = plt.figure(figsize=(13, 4.5))
        ax3 = fig.add_subplot(1, 3, 1, projection="3d")
        plot_path_3d(traj, ax=ax3)
        plot_arm(arm, traj.q[[0, -1]], ax=ax3, dims=3, orientation_arrow=False)
        ax3.set_title("Figure 8.1: gripper path (start red, end green)")
        ax = fig.add_subplot(1, 3, 2)
        plot_time_series(traj, "x", ax=ax)
        ax.set_title("x, y, z against time")
        ax = fig.add_subplot(1, 3, 3)
        plot_time_series(traj, "q", ax=ax)
        ax.set_title("joint angles (IK, elbow up)")
        fig.tight_layout()
        fig.savefig(out / "cubic_path.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Figures 8.2-8.4: displacement, velocity and acceleration

        The seed's "displacement" (its MATLAB `u = sqrt(ux.^2 + uy.^2 + uz.^2)`) is the distance
        of the gripper **from the base origin**, not the distance travelled; both are drawn. Its
        acceleration graph is the magnitude with the sign flipped by hand after sample 27
        (`uacc(27:51) = -uacc(27:51)`); the signed acceleration along the path is drawn instead.
        """),
        code(r"""
        travelled = (traj.x - u0) @ direction
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
        axes[0].plot(traj.t, np.linalg.norm(traj.x, axis=1) * 1e3, label="distance from base (seed's 'displacement')")
        axes[0].plot(traj.t, travelled * 1e3, label="distance travelled along the line")
        axes[0].set(xlabel="t [s]", ylabel="[mm]", title="Figure 8.2: displacement")
        axes[0].legend(fontsize=7)
        plot_time_series(traj, "speed", ax=axes[1], units="m")
        axes[1].set_title("Figure 8.3: speed")
        axes[2].plot(traj.t, accel_along, label="along the path (signed)")
        axes[2].plot(traj.t, np.linalg.norm(traj.xdd, axis=1), "--", label="magnitude")
        axes[2].set(xlabel="t [s]", ylabel="acceleration [m/s$^2$]", title="Figure 8.4: acceleration")
        axes[2].legend(fontsize=7)
        for ax in axes:
            ax.grid(True)
        fig.tight_layout()
        fig.savefig(out / "cubic_time_graphs.png", dpi=110)
        plt.show()
        jerk_gradient = float(np.polyfit(traj.t, accel_along, 1)[0])
        print(f"peak speed {speed.max():.4f} m/s = 1.5 x {np.linalg.norm(uf - u0):.4f} m / {duration:g} s; "
              f"acceleration gradient (jerk) {jerk_gradient:.5f} m/s^3")
        """),
        md(r"""
        ## Discrepancies in the published text

        * Peak speed: the seed reads **0.045 m/s** from its graph; the exact value is
          $1.5\,\lVert u_f - u_0\rVert / t_f = 0.0446$ m/s (0.045 is its 2-significant-figure
          rounding; stated as a reading at 3 figures it would be 0.0446).
        * The jerk "-0.0143 (3 s.f.)" is right: $-12\lVert u_f - u_0\rVert/t_f^3 = -0.01428$ m/s$^3$.
        * The analysis says the line goes "from (0.05, 0, 0.1) to (0.04, 0.03, 0.01)" and the
          MATLAB appendix C uses (0.04, 0.03, 0.02) -> (0.05, 0, 0.1): neither is the stated input,
          and neither gives the published peak speed (computed below) - the figures came from the
          stated input.
        * The videos of section IV.3 go from the same start to (0.1, 0.15, -0.2), (-0.2, 0.1, -0.1)
          and (0.2, 0.1, -0.1): all three lines are feasible on the elbow-up branch (below).
        """),
        code(r"""
        alternatives = {"stated input (0, 0.18, -0.094) -> (0.1, 0.15, -0.2)": (u0, uf),
                        "text (0.05, 0, 0.1) -> (0.04, 0.03, 0.01)": ([0.05, 0, 0.1], [0.04, 0.03, 0.01]),
                        "appendix C (0.04, 0.03, 0.02) -> (0.05, 0, 0.1)": ([0.04, 0.03, 0.02], [0.05, 0, 0.1])}
        t_fine = np.linspace(0, duration, 501)
        peak = {k: float(np.linalg.norm(cubic(np.asarray(a, float), np.asarray(b, float), duration).velocity(t_fine), axis=-1).max())
                for k, (a, b) in alternatives.items()}
        display(pd.Series(peak, name="peak speed [m/s]").round(4).to_frame())
        videos = {}
        for goal in ([0.1, 0.15, -0.2], [-0.2, 0.1, -0.1], [0.2, 0.1, -0.1]):
            v = cartesian_trajectory(arm, line(u0, goal), duration, dt=dt, branch="elbow_up")
            videos[str(goal)] = {"samples": len(v.t), "max joint speed [deg/s]": np.degrees(np.abs(v.qd)).max()}
        pd.DataFrame(videos).T.round(1)
        """),
        md(r"""
        ## Checks against the published numbers

        Peak speed published as 0.045 (2 s.f.): tolerance 0.0005 m/s; its time 2.5 s; the jerk
        -0.0143 (3 s.f.): tolerance 0.00005. The line is the per-axis cubic to 1e-12 m.
        """),
        code(r"""
        checks.check("peak speed [m/s] (IV.2)", speed.max(), 0.045, tol=0.0005, note="2 s.f.; exact 0.0446")
        checks.check("time of the peak speed [s] (IV.2)", traj.t[np.argmax(speed)], 2.5, tol=dt / 2, note="mid-trajectory")
        checks.check("acceleration gradient [m/s^3] (IV.2)", jerk_gradient, -0.0143, tol=0.00005, note="3 s.f.")
        checks.check("line path == per-axis cubics [m]", per_axis, 0.0, tol=1e-12, note="seed's X(t), Y(t), Z(t)")
        checks.check("a2 [m/s^2]", law.coefficients[0][2], 3 / duration**2 * (uf - u0), tol=1e-15, note="3 (uf - u0) / tf^2")
        checks.check("a3 [m/s^3]", law.coefficients[0][3], -2 / duration**3 * (uf - u0), tol=1e-15, note="-2 (uf - u0) / tf^3")
        checks.typo("peak speed to 3 s.f. [m/s]", 0.045, round(float(speed.max()), 4), "the graph reading 0.045 is 0.0446 rounded")
        checks.typo("path endpoints in the text (IV.2) [m]", [0.05, 0, 0.1, 0.04, 0.03, 0.01], np.r_[u0, uf],
                    "the analysis text names other endpoints than the input")
        checks.assert_all()
        """),
    ]


def seed000_pick_place():
    name = "06_pick_and_place"
    return name, "Seed 000, IV.3: two-stage pick and place on the arm, streamed as polynomial segments", [
        md(rf"""
        # Two-stage pick and place on the arm, streamed as polynomial segments

        Reproduces seed {SEED000}, **section IV.3 "Coding Trajectory Planning on Arduino"** and
        its pick-and-place demo: the gripper first moves above the object, then straight down
        (the seed's fix for dislodging the object), grips, lifts, and places it elsewhere the same
        way. Every leg is a cubic straight line with IK at every 0.1 s.

        The seed's Arduino stored the whole angle list in arrays and ran out of memory
        ("stability problems, or the Arduino code will not compile"). The fix here: the host
        turns each leg into **cubic polynomial segments** and streams them into the board's small
        segment queue (`labkit.arm.Arm.run_trajectory`), so the board's memory use does not
        grow with the trajectory. Runs on the simulated arm by default (`port = "sim://..."`).
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        port = {SIM_PORT}  # the simulated arm; a real board: /dev/ttyACM0
        home = [0.0, 0.18, -0.094]      # start and end [m] (the seed's start point)
        pick = [0.10, 0.15, -0.20]      # object [m] (the seed's first video target)
        place = [-0.12, 0.14, -0.16]    # where to put it [m]
        approach_height = 0.05          # first stage ends this far above the object [m]
        leg_duration = 1.5              # each leg [s]
        dt = 0.1                        # IK sample step [s]
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.arm import Arm, segments_from_trajectory
        from labkit.kinematics import fk_position
        from labkit.motion import cartesian_trajectory, line
        from labkit.plotting import plot_arm, plot_path_3d
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        model = Robot.load(robot)
        checks = Checks("Seed 000 IV.3: pick and place on the arm")
        home, pick, place = (np.asarray(p, float) for p in (home, pick, place))
        up = np.array([0.0, 0.0, approach_height])
        legs = [("home -> above object", home, pick + up, None),
                ("down to the object", pick + up, pick, "close"),
                ("lift", pick, pick + up, None),
                ("above the place", pick + up, place + up, None),
                ("down to the place", place + up, place, "open"),
                ("lift", place, place + up, None),
                ("home", place + up, home, None)]
        """),
        md(r"""
        ## Plan every leg (IK at every sample, limits checked before anything moves)
        """),
        code(r"""
        plans = [cartesian_trajectory(model, line(a, b), leg_duration, dt=dt, branch="elbow_up") for _, a, b, _ in legs]
        segments = [segments_from_trajectory(p) for p in plans]
        plan_table = pd.DataFrame({
            "leg": [l[0] for l in legs],
            "from [mm]": [np.round(l[1] * 1e3).astype(int).tolist() for l in legs],
            "to [mm]": [np.round(l[2] * 1e3).astype(int).tolist() for l in legs],
            "samples": [len(p.t) for p in plans],
            "segments streamed": [len(s) for s in segments],
            "gripper after": [l[3] or "" for l in legs],
        })
        plan_table
        """),
        md(r"""
        ## Memory: stored arrays (seed) vs streamed segments

        The seed's first version stored, per trajectory (5 s sampled every 0.1 s), 51 times,
        3 x 51 coordinates and 3 x 51 angles as 4-byte floats; its two-stage version doubled that.
        An ATmega328P (Arduino Uno) has 2048 bytes of SRAM in all - for the arrays, the stack, the
        serial buffers and the servo library. Its fix (store only the coordinates, solve IK on the
        fly) still needs most of it. Streaming keeps at most `queue` segments (12 coefficients
        each) on the board whatever the length; the board reports the least free memory it has
        seen (`Status.mem`, a stack canary).
        """),
        code(r"""
        SRAM = 2048
        seed_samples = int(round(5.0 / 0.1)) + 1
        memory = pd.Series({
            "seed, one trajectory (t, xyz, angles)": 4 * seed_samples * (1 + 3 + 3),
            "seed, two-stage (t, xyz, angles)": 2 * 4 * seed_samples * (1 + 3 + 3),
            "seed's fix, two-stage (t, xyz only)": 2 * 4 * seed_samples * (1 + 3),
            "streamed: queue of 6 segments x 12 coefficients": 6 * 12 * 4,
        }, name="bytes")
        memory.to_frame().assign(**{"share of 2048 B SRAM": (memory / SRAM).round(2)})
        """),
        md(r"""
        ## Run it on the arm
        """),
        code(r"""
        log, reports = [], []
        with Arm(port, robot=robot) as arm:
            arm.set_host_timeout(5.0)
            arm.open_gripper()
            arm.move_joints(plans[0].q[0], wait=True)
            for (label, a, b, gripper), plan in zip(legs, plans):
                report = arm.run_trajectory(plan, wait=True)
                q_meas = arm.wait_settled(plan.q[-1], tol=np.radians(2.0))
                if gripper == "close":
                    arm.close_gripper()
                    arm.sleep(0.3)
                elif gripper == "open":
                    arm.open_gripper()
                    arm.sleep(0.3)
                status = arm.status()
                reports.append(report)
                log.append({"leg": label, "target [mm]": np.round(b * 1e3, 1).tolist(),
                            "measured [mm]": np.round(fk_position(model, q_meas) * 1e3, 1).tolist(),
                            "error [mm]": 1e3 * np.linalg.norm(fk_position(model, q_meas) - b),
                            "segments": report.segments, "underruns": report.underruns,
                            "queue-full waits": report.queue_full_waits, "gripper [us]": status.grip_us,
                            "board min free memory [bytes]": status.mem})
            arm.set_host_timeout(0.5)
            info = arm.info
        run = pd.DataFrame(log)
        run.to_csv(out / "pick_and_place_run.csv", index=False)
        print(f"board: firmware {info.firmware}, segment queue {info.queue}")
        run.round(2)
        """),
        code(r"""
        fig = plt.figure(figsize=(7.5, 6))
        ax = fig.add_subplot(projection="3d")
        path = np.concatenate([p.x for p in plans])
        plot_path_3d(path, ax=ax, label="planned gripper path")
        plot_arm(model, plans[1].q[-1], ax=ax, dims=3, color="C1", label="gripping", orientation_arrow=False)
        plot_arm(model, plans[4].q[-1], ax=ax, dims=3, color="C4", label="placing", orientation_arrow=False)
        measured = np.array(run["measured [mm]"].tolist())
        ax.scatter(*measured.T, color="k", marker="x", s=30, label="measured stops")
        ax.set_title("two-stage pick and place (approach from above)")
        ax.legend(fontsize=7, loc="upper left")
        fig.savefig(out / "pick_and_place.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Checks

        No published numbers (videos only). Checked: every stop within 10 mm of its target (the
        simulated servos carry random zero offsets of about 1 deg, like real ones); the gripper
        closed at the object and open at the place (robot file's pulse widths); the stream never
        ran dry (no underruns); the two approach legs are vertical (x, y unchanged to 1e-12 m);
        the board's free memory stays above 200 bytes; and the seed's memory problem is real: its
        two-stage arrays alone need more than the Uno's 2048 bytes.
        """),
        code(r"""
        checks.check("stop errors [mm]", run["error [mm]"].max(), 0.0, tol=10.0, note="servo zero offsets ~1 deg")
        checks.check("gripper closed at the object [us]", run.loc[1, "gripper [us]"], model.gripper.closed_us, tol=0, note="robot file")
        checks.check("gripper open at the place [us]", run.loc[4, "gripper [us]"], model.gripper.open_us, tol=0, note="robot file")
        checks.check("stream underruns", run["underruns"].sum(), 0, tol=0, note="queue kept fed")
        checks.check("approach legs vertical [m]", max(np.abs(plans[i].x[:, :2] - plans[i].x[0, :2]).max() for i in (1, 4)), 0.0,
                     tol=1e-12, note="second stage moves only z")
        checks.check("board free memory above 200 bytes", float(run["board min free memory [bytes]"].min() > 200), 1.0, tol=0,
                     note=f"min {run['board min free memory [bytes]'].min()} bytes")
        checks.check("seed's two-stage arrays exceed the SRAM", float(memory.iloc[1] > SRAM), 1.0, tol=0,
                     note=f"{memory.iloc[1]} B > 2048 B: 'will not compile'")
        checks.assert_all()
        """),
    ]


def seed000_calibration():
    name = "07_calibration"
    return name, "Seed 000, II.4 extended: kinematic calibration to tables 1-3", [
        md(rf"""
        # Kinematic calibration of the arm to tables 1-3

        Extends seed {SEED000}, **section II.4 (Checking the Calculations) and its conclusion**
        ("to improve the calculations the team can consider the vertical component of the weight
        of the robot arm"): the model's joint zero offsets and link lengths (and, in a second fit,
        a gravity-sag term) are fitted by least squares to the 15 measured poses of tables 1-3,
        with confidence intervals, residuals before/after, and a leave-one-pose-out check that
        shows whether the fit generalises or only follows the reading errors.
        Library: `labkit.measure` (`calibrate`, `load_measurements`, `error_table`).
        """),
        parameters(f"""
        robot = "arduino_arm_3dof"
        measurements = "seed000_fk_tables1-3.csv"
        output_dir = {out_default(LAB000, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.data import measurement_file
        from labkit.measure import calibrate, error_table, load_measurements
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 000 calibration")
        path = Path(measurements) if Path(measurements).exists() else measurement_file(measurements)
        readings = load_measurements(path)
        fits = {
            "joint offsets": calibrate(readings, arm, params=("joint_offsets",)),
            "offsets + lengths": calibrate(readings, arm, params=("joint_offsets", "link_lengths")),
            "offsets + gravity sag": calibrate(readings, arm, params=("joint_offsets", "gravity_sag")),
        }
        comparison = pd.DataFrame({k: {"parameters": len(r.names), "RMS before [mm]": r.rms_before * 1e3,
                                       "RMS after [mm]": r.rms_after * 1e3, "leave-one-pose-out RMS [mm]": r.loo_rms * 1e3}
                                   for k, r in fits.items()}).T
        comparison.round(2)
        """),
        md(r"""
        ## The fitted parameters (offsets + lengths), 95 % confidence intervals
        """),
        code(r"""
        best = fits["offsets + lengths"]
        print(best.summary())
        best.parameters()
        """),
        code(r"""
        res = best.to_dataframe()
        res["label"] = res.pose_id.str.replace("deg", "") + " " + res.axis
        fig, ax = plt.subplots(figsize=(13, 3.8))
        xpos = np.arange(len(res))
        for k, (col, name) in enumerate([("before", "nominal model"), ("after", "calibrated"), ("leave_one_out", "leave one pose out")]):
            ax.bar(xpos + (k - 1) * 0.27, res[col], width=0.27, label=name)
        ax.set_xticks(xpos, res.label, rotation=90, fontsize=6)
        ax.set(ylabel="measured - model [mm]", title="residuals of tables 1-3 before and after calibration")
        ax.grid(True, axis="y")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "calibration_residuals.png", dpi=110)
        plt.show()
        best.write_robot(out / "arduino_arm_3dof_calibrated.toml")
        print("calibrated robot file:", out / "arduino_arm_3dof_calibrated.toml")
        """),
        md(r"""
        ## Interpretation

        The error shrinks only a little (RMS about 14.5 -> 12.4 mm), and the leave-one-pose-out
        RMS is back near the uncalibrated value: the fitted offsets have confidence intervals
        wider than their values. The table errors are dominated by **reading** errors (ruler
        readings with ± 1-5 cm ranges, the copied table-3 value), not by a systematic model error
        that calibration could remove. The gravity-sag term, which the seed proposes, does not
        generalise either: table 2's measured z is *above* the model, the wrong sign for a sag
        (see `02_fk_check_tables.ipynb`). Better data (repeated readings with a fixed jig) would be
        needed before a calibrated robot file is worth using.
        """),
        md(r"""
        ## Checks

        The seed publishes no calibration. Checked: the "before" RMS equals the RMS of the error
        table of `02_fk_check_tables` (same model, same data; 1e-12 m), every fit reduces the fit
        residual, and the leave-one-pose-out RMS is at least the fit RMS (as it must be).
        """),
        code(r"""
        errors = error_table(readings, arm).table
        checks.check("RMS before = error-table RMS [m]", best.rms_before, np.sqrt(np.mean(errors.error**2)), tol=1e-12,
                     note="consistent with tables 1-3")
        for k, r in fits.items():
            checks.check(f"{k}: RMS after <= before", float(r.rms_after <= r.rms_before), 1.0, tol=0, note=f"{r.rms_after*1e3:.2f} mm")
            checks.check(f"{k}: leave-one-out >= fit RMS", float(r.loo_rms >= r.rms_after), 1.0, tol=0, note=f"{r.loo_rms*1e3:.2f} mm")
        checks.assert_all()
        """),
    ]


# --------------------------------------------------------------------------------------------
# seed 003: planar 3R (ROBT403 lab 3)
# --------------------------------------------------------------------------------------------


def seed003_fk_workspace():
    name = "01_fk_workspace"
    return name, "Seed 003, task 1: DH, forward kinematics and workspace (+-90, +-45 deg)", [
        md(rf"""
        # Planar 3R: DH table, forward kinematics and the workspace

        Reproduces seed {SEED003}, **task 1 (sections II.A-C)**: the DH table ($a_1 = a_2 = 145$ mm,
        end-effector 45 mm beyond joint 3), the link transforms and their product $T^0_{{EE}}$,
        and the workspace plots of figures 1 and 2 (joint ranges $\pm 90^\circ$ and $\pm 45^\circ$,
        drawn with the demonstration lengths 135, 135 and 46.7 mm that the seed uses there).

        Found, not copied: the seed's transforms mix two conventions (a modified-DH table with
        standard-DH matrices), and its final $T^0_{{EE}}$ position is wrong (shown below).
        Robot files: `planar3r_seed003` (145/145/45 mm), `planar3r_seed003_135` (135/135/46.7 mm).
        Library: `labkit.kinematics.symbolic`, `labkit.kinematics` (FK, workspace), `labkit.plotting`.
        """),
        parameters(f"""
        robot = "planar3r_seed003"            # the lab's arm (task 1 DH table)
        demo_robot = "planar3r_seed003_135"   # lengths of the workspace figures
        n_samples = 20000                     # random joint samples per workspace plot
        output_dir = {out_default(LAB003, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd
        import sympy as sp

        from labkit.kinematics import fk_position, planar_region, symbolic, workspace_points
        from labkit.plotting import plot_arm, plot_workspace
        from labkit.reports import Checks, show_latex
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        demo = Robot.load(demo_robot)
        checks = Checks("Seed 003 task 1: reproduced vs published")
        arm.dh_table()
        """),
        md(r"""
        ## Link transforms and $T^0_{EE}$ (modified DH, as the table)

        Lengths in mm. The chain ends with the 45 mm tool translation $T^3_{EE}$.
        """),
        code(r"""
        q = sp.symbols("theta1:4", real=True)
        A = symbolic.link_transforms(arm, q=list(q), length_unit="mm")
        for i, Ai in enumerate(A):
            show_latex(Ai, prefix=f"T^{{{i}}}_{{{i + 1}}} = ")
        T_EE = symbolic.forward_kinematics(arm, q=list(q), length_unit="mm")
        show_latex(T_EE, prefix="T^0_{EE} = ")
        """),
        md(r"""
        ## The published $T^0_{EE}$, tested

        The seed writes $T^1_2$ with translation $(145\cos\theta_2, 145\sin\theta_2)$ - the
        *standard*-DH form - under a *modified*-DH table, where the translation is $(a_1, 0) =
        (145, 0)$; its final position is
        $x = 145(c_{12} + c_{123}) + 45 c_{123}$, $y = 145(s_{12} + s_{123}) + 45 s_{123}$.
        The correct one (table, either convention read consistently) is
        $x = 145 c_1 + 145 c_{12} + 45 c_{123}$. The two agree only when $\theta_2 + \theta_3 = 0$
        (as at $q = 0$, where a check is usually made): at $q = (0, 90^\circ, 0)$ the seed's formula
        puts the tool at (0, 335) mm, the arm is at (145, 190) mm.
        """),
        code(r"""
        t1, t2, t3 = q
        c, s = sp.cos, sp.sin
        published_xy = sp.Matrix([145 * (c(t1 + t2) + c(t1 + t2 + t3)) + 45 * c(t1 + t2 + t3),
                                  145 * (s(t1 + t2) + s(t1 + t2 + t3)) + 45 * s(t1 + t2 + t3)])
        correct_xy = sp.simplify(T_EE[:2, 3])
        show_latex(correct_xy, prefix="p_{xy} = ")
        published_f = sp.lambdify([q], published_xy, "numpy")
        rng = np.random.default_rng(0)
        Q = rng.uniform(-np.pi / 2, np.pi / 2, size=(1000, 3))
        labkit_xy = fk_position(arm, Q)[:, :2] * 1e3
        seed_xy = np.stack([np.ravel(published_f(qq)) for qq in Q])
        seed_error = np.linalg.norm(seed_xy - labkit_xy, axis=1)
        example = np.radians([0.0, 90.0, 0.0])
        print("q = (0, 90, 0) deg: labkit", np.round(fk_position(arm, example)[:2] * 1e3, 1),
              "mm, seed's formula", np.round(np.ravel(published_f(example)), 1), "mm")
        print(f"seed's formula vs FK over 1000 random q: median error {np.median(seed_error):.0f} mm, max {seed_error.max():.0f} mm")
        symbolic_vs_numeric = np.abs(np.stack([np.ravel(sp.lambdify([q], correct_xy, "numpy")(qq)) for qq in Q[:200]])
                                     - labkit_xy[:200]).max()
        """),
        md(r"""
        ## Workspace: figure 1 ($\pm 90^\circ$) and figure 2 ($\pm 45^\circ$)

        Random joint samples through batched FK (`labkit.kinematics.workspace_points`), as dots and as the filled
        region with its boundary; the area is measured on the occupancy grid.
        """),
        code(r"""
        ranges = {"+-90 deg (figure 1)": np.radians([[-90, 90]] * 3), "+-45 deg (figure 2)": np.radians([[-45, 45]] * 3)}
        fig, axes = plt.subplots(1, 2, figsize=(12, 5.2))
        areas, reach = {}, {}
        for ax, (label, jr) in zip(axes, ranges.items()):
            plot_workspace(demo, jr, ax=ax, n=n_samples, kind="scatter", label="reachable tool points")
            plot_arm(demo, np.zeros(3), ax=ax, color="k", label="q = 0")
            ws = workspace_points(demo, jr, n=n_samples, seed=0)
            areas[label] = planar_region(ws).area * 1e4  # m^2 -> cm^2
            reach[label] = np.linalg.norm(ws.points[:, :2], axis=1).max() * 1e3
            ax.set_title(f"{demo.name}: joints {label}")
            ax.legend(loc="lower left", fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "workspace.png", dpi=110)
        plt.show()
        pd.DataFrame({"area [cm^2]": areas, "max reach of the samples [mm]": reach}).round(1)
        """),
        md(r"""
        ## Checks

        The seed publishes no workspace numbers; checked: the reach of both arms at $q = 0$
        ($a_1 + a_2 + L_3$ = 335 and 316.7 mm, published lengths to 0.1 mm), no sample beyond it,
        the $\pm 45^\circ$ workspace inside the $\pm 90^\circ$ one (smaller area), the symbolic
        closed form against the numeric FK (1e-9 mm), and the published $T^0_{EE}$ recorded as wrong.
        """),
        code(r"""
        checks.check("reach of the lab arm at q = 0 [mm]", fk_position(arm, np.zeros(3))[0] * 1e3, 335, tol=0.05, note="145 + 145 + 45")
        checks.check("reach of the demo arm at q = 0 [mm]", fk_position(demo, np.zeros(3))[0] * 1e3, 316.7, tol=0.05,
                     note="135 + 135 + 46.7")
        checks.check("no workspace sample beyond the reach", float(max(reach.values()) <= 316.7 + 1e-9), 1.0, tol=0, note="")
        a90, a45 = areas.values()
        checks.check("+-45 deg workspace smaller than +-90 deg", float(a45 < a90), 1.0, tol=0, note=f"{a45:.0f} < {a90:.0f} cm^2")
        checks.check("symbolic T0_EE position vs numeric FK [mm]", symbolic_vs_numeric, 0.0, tol=1e-9, note="200 random q")
        checks.typo("published T0_EE position at q = (0, 90, 0) deg [mm]", np.ravel(published_f(example)),
                    fk_position(arm, example)[:2] * 1e3, "standard-DH matrices under a modified-DH table; c12 + c123 should be c1 + c12")
        checks.assert_all()
        """),
    ]


def seed003_cubic():
    name = "02_cubic_joint_trajectories"
    return name, "Seed 003, task 2: cubic joint trajectories (coefficients and plots)", [
        md(rf"""
        # Cubic joint trajectories

        Reproduces seed {SEED003}, **task 2 (section II.D)**: `cubic_coefficients` and
        `cubic_trajectory` for joint 1: 0 -> -0.8 rad, joint 2: 0 -> 0.8 rad and joint 3:
        1.57 -> 0.8 rad in 5 s (rest to rest), the coefficient table and the joint angles (and
        rates, accelerations) against time, checked against the robot's joint limits.
        Library: `labkit.motion` (`joint_trajectory`), `labkit.plotting`.
        """),
        parameters(f"""
        robot = "planar3r_seed003"
        q_start = [0.0, 0.0, 1.57]   # [rad]
        q_end = [-0.8, 0.8, 0.8]     # [rad]
        duration = 5.0               # [s]
        dt = 0.05                    # sample step [s]
        output_dir = {out_default(LAB003, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np

        from labkit.motion import joint_trajectory
        from labkit.plotting import plot_arm, plot_trajectory
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 003 task 2: cubic joint trajectories")
        q0, qf = np.asarray(q_start, float), np.asarray(q_end, float)
        traj = joint_trajectory(q0, qf, duration, robot=arm, law="cubic", dt=dt)  # limits checked
        coefficients = traj.law.coefficient_table(list(arm.joint_names))
        coefficients.to_csv(out / "cubic_coefficients.csv")
        coefficients
        """),
        md(r"""
        $q(t) = a_0 + a_1 t + a_2 t^2 + a_3 t^3$ with $a_0 = q_0$, $a_1 = 0$,
        $a_2 = 3(q_f - q_0)/T^2$, $a_3 = -2(q_f - q_0)/T^3$.
        """),
        code(r"""
        axes = plot_trajectory(traj, title="Cubic joint trajectories, 5 s (seed 003 task 2)")
        axes[0].figure.savefig(out / "cubic_joint_trajectories.png", dpi=110)
        plt.show()
        traj.to_dataframe(degrees=False).iloc[::20].round(4)
        """),
        code(r"""
        ax = plot_arm(arm, traj.q[:: max(1, len(traj.t) // 8)])
        ax.set_title("the arm along the trajectory (start red, end green)")
        plt.show()
        """),
        md(r"""
        ## Checks

        The seed prints no coefficients; they are checked against the closed form (1e-12), with
        the end conditions (positions, zero velocities) and the peak rates $1.5\,|q_f - q_0|/T$
        at $t = T/2$.
        """),
        code(r"""
        a = traj.law.coefficients[0]
        checks.check("a0 [rad]", a[0], q0, tol=1e-12, note="q0")
        checks.check("a1 [rad/s]", a[1], np.zeros(3), tol=1e-12, note="rest")
        checks.check("a2 [rad/s^2]", a[2], 3 * (qf - q0) / duration**2, tol=1e-12, note="3 (qf - q0) / T^2 = -0.096, 0.096, -0.0924")
        checks.check("a3 [rad/s^3]", a[3], -2 * (qf - q0) / duration**3, tol=1e-12, note="-2 (qf - q0) / T^3")
        checks.check("end position [rad]", traj.q[-1], qf, tol=1e-12, note="")
        checks.check("end velocity [rad/s]", traj.qd[-1], np.zeros(3), tol=1e-12, note="")
        checks.check("peak rates [rad/s]", np.abs(traj.qd).max(axis=0), 1.5 * np.abs(qf - q0) / duration, tol=1e-12,
                     note="at t = T/2 (sampled)")
        checks.assert_all()
        """),
    ]


def seed003_ik_click():
    name = "03_ik_orientation_click"
    return name, "Seed 003, task 3: IK with orientation and the click-to-reach workspace plot", [
        md(rf"""
        # Inverse kinematics with orientation, and click-to-reach on the workspace plot

        Reproduces seed {SEED003}, **task 3 (section II.E)**: `inverse_kinematics_with_orientation`
        for $(x, y, \phi)$ - wrist point $x_w = x - L_3\cos\phi$, $y_w = y - L_3\sin\phi$
        (eqs. 1-2, 14-15), $\cos\theta_2$ by the cosine law (6, 16), both signs of $\theta_2$ (7, 17),
        $\theta_1$ (12, 18) and $\theta_3 = \phi - \theta_1 - \theta_2$ (13, 19) - and the interactive
        plot where a click on the workspace gives the joint angles (figure 3) or, outside the
        workspace, none (figure 4).

        Found, not copied: eqs. (10)-(11) define $k_1 = l_2\cos(\theta_1 + \theta_2)$,
        $k_2 = l_2\sin(\theta_1 + \theta_2)$, which makes eq. (12) circular and wrong; the standard
        result is $k_1 = l_1 + l_2\cos\theta_2$, $k_2 = l_2\sin\theta_2$.

        Live clicking needs `ipympl` (`%matplotlib widget`); without it, and in rendered reports,
        the clicks listed in the parameters are replayed through the same handler (static figure).
        Library: `labkit.kinematics` (`ik`, `ik_all`), `labkit.plotting`.
        """),
        parameters(f"""
        robot = "planar3r_seed003_135"    # the seed's example application (135/135/46.7 mm)
        clicks = [[0.20, 0.15], [0.05, 0.28], [0.33, 0.12]]  # clicked points [m]; the last is outside the workspace
        click_phi_deg = 30.0              # tool orientation requested at a click [deg]
        target = [0.20, 0.15, 0.5236]     # (x [m], y [m], phi [rad]) for the worked example
        output_dir = {out_default(LAB003, name)}
        """),
        code(r"""
        import importlib.util
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.exceptions import JointLimitError, UnreachableError
        from labkit.kinematics import fk, ik, ik_all
        from labkit.plotting import plot_arm, plot_workspace
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 003 task 3: IK with orientation")
        l1, l2, L3 = float(arm.a[1]), float(arm.a[2]), float(arm.tool[0, 3])
        print(f"l1 = {l1 * 1e3:.1f} mm, l2 = {l2 * 1e3:.1f} mm, L3 = {L3 * 1e3:.1f} mm")
        """),
        md(r"""
        ## The worked example: both branches, FK round trip

        `ik_all` returns both signs of $\theta_2$ with their branch names; `valid` says whether a
        solution is inside the joint limits ($\pm 90^\circ$).
        """),
        code(r"""
        sols = ik_all(arm, target)
        table = sols.to_dataframe()
        T = fk(arm, sols.q)
        table["x [mm]"] = T[:, 0, 3] * 1e3
        table["y [mm]"] = T[:, 1, 3] * 1e3
        table["phi [deg]"] = np.degrees(np.arctan2(T[:, 1, 0], T[:, 0, 0]))
        round_trip = float(np.max(np.abs(np.c_[T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])] - target)))
        table.round(4)
        """),
        md(r"""
        ## Eq. (12) with the published $k_1, k_2$ vs the standard ones

        Evaluated on the valid solution (using its true $\theta_1$ to make the circular published
        form computable at all):
        """),
        code(r"""
        q_ok = sols.q[np.argmax(sols.valid)]
        x, y, phi = target
        xw, yw = x - L3 * np.cos(phi), y - L3 * np.sin(phi)
        th1, th2 = q_ok[0], q_ok[1]
        theta1_published = np.arctan2(yw, xw) - np.arctan2(l2 * np.sin(th1 + th2), l2 * np.cos(th1 + th2))
        theta1_standard = np.arctan2(yw, xw) - np.arctan2(l2 * np.sin(th2), l1 + l2 * np.cos(th2))
        print(f"theta1: labkit {np.degrees(th1):.4f} deg, eq. (12) with the standard k {np.degrees(theta1_standard):.4f} deg, "
              f"with the published k {np.degrees(theta1_published):.4f} deg")
        """),
        md(r"""
        ## Click to reach (figures 3 and 4)

        `on_click` is the handler: it solves IK at the clicked $(x, y)$ with the requested $\phi$,
        draws the arm and prints the joint angles, or says why there are none (out of reach, by
        how much; or reachable only outside the joint limits).
        """),
        code(r"""
        phi_click = np.radians(click_phi_deg)
        live = importlib.util.find_spec("ipympl") is not None and "widget" in plt.get_backend().lower()
        fig, ax = plt.subplots(figsize=(7, 6))
        plot_workspace(arm, ax=ax, n=15000, label="workspace (tool point, joint limits)")
        ax.set_title("click to reach (phi = %g deg)" % click_phi_deg)
        click_log = []


        def on_click(event):
            if event.xdata is None or event.ydata is None:
                return
            x, y = event.xdata / 1e3, event.ydata / 1e3  # axes are in mm
            try:
                q = ik(arm, [x, y, phi_click])
            except (UnreachableError, JointLimitError) as exc:
                why = "out of reach" if isinstance(exc, UnreachableError) else "outside the joint limits"
                ax.plot(event.xdata, event.ydata, "kx", ms=10)
                ax.annotate(why, (event.xdata, event.ydata), textcoords="offset points", xytext=(5, 5), fontsize=8)
                click_log.append({"x [mm]": event.xdata, "y [mm]": event.ydata, "result": why, **{f"q{j} [deg]": None for j in (1, 2, 3)}})
                print(f"({x:.3f}, {y:.3f}) m: no joint angles - {exc}")
            else:
                plot_arm(arm, q, ax=ax, color="C%d" % (len(click_log) % 10))
                click_log.append({"x [mm]": event.xdata, "y [mm]": event.ydata, "result": "reached",
                                  **{f"q{j + 1} [deg]": v for j, v in enumerate(np.degrees(q))}})
                print(f"({x:.3f}, {y:.3f}) m -> q = {np.round(np.degrees(q), 2)} deg")
            fig.canvas.draw_idle()


        if live:
            fig.canvas.mpl_connect("button_press_event", on_click)
            print("click on the workspace")
        # replay the clicks of the parameters through the same handler (a static figure in reports)
        from types import SimpleNamespace
        for cx, cy in clicks:
            on_click(SimpleNamespace(xdata=cx * 1e3, ydata=cy * 1e3))
        fig.savefig(out / "click_to_reach.png", dpi=110)
        plt.show()
        pd.DataFrame(click_log).round(2)
        """),
        md(r"""
        ## The same with sliders (ipywidgets; a snapshot in reports)
        """),
        code(r"""
        import ipywidgets as widgets

        def _reach(x_mm=200.0, y_mm=150.0, phi_deg=30.0):
            try:
                sols_w = ik_all(arm, [x_mm / 1e3, y_mm / 1e3, np.radians(phi_deg)])
            except UnreachableError as exc:
                print("out of reach:", exc)
                return
            for b, q, ok, reach_ok in zip(sols_w.branches, sols_w.q, sols_w.valid, sols_w.reachable):
                state = "valid" if ok else ("outside the limits" if reach_ok else "unreachable")
                print(f"{b:>11}: q = {np.round(np.degrees(q), 2)} deg ({state})")

        widgets.interact(_reach, x_mm=(-320.0, 320.0, 1.0), y_mm=(-320.0, 320.0, 1.0), phi_deg=(-180.0, 180.0, 1.0));
        """),
        md(r"""
        ## Checks

        No angles are published for the seed's clicks. Checked: FK of every IK branch returns the
        target (1e-12 m / rad), the standard eq. (12) gives labkit's $\theta_1$ (1e-12 rad) while the
        published $k$ do not (recorded as a typo), the clicks inside the workspace are reached and
        the one outside (0.351 m from the base, reach 0.317 m) is refused.
        """),
        code(r"""
        checks.check("FK(IK(target)) - target, both branches", round_trip, 0.0, tol=1e-12, note="x, y [m], phi [rad]")
        checks.check("eq. (12) with standard k1, k2 [rad]", theta1_standard, th1, tol=1e-12, note="k1 = l1 + l2 c2, k2 = l2 s2")
        checks.check("clicks reached / refused", [r["result"] == "reached" for r in click_log], [True, True, False], tol=0,
                     note="last click outside the workspace")
        checks.typo("eq. (12) with the published k1, k2 [deg]", np.degrees(theta1_published), np.degrees(th1),
                    "k1 = l2 cos(theta1 + theta2) makes eq. (12) circular")
        checks.assert_all()
        """),
    ]


def seed003_plot_manipulator():
    name = "04_plot_manipulator"
    return name, "Seed 003, task 4: plot_manipulator with start (red) and end (green)", [
        md(rf"""
        # Plotting the manipulator along a trajectory: start red, end green

        Reproduces seed {SEED003}, **task 4 (section II.F)**: `plot_manipulator` (joints, links and
        an arrow for the end-effector orientation), a cubic joint trajectory between a random
        start and end configuration, and `plot_trajectory_within_workspace`: the workspace, the
        end-effector path, the start configuration in red and the end in green (figures 7-10; two
        random examples, seeded so that reports are reproducible).
        Library: `labkit.plotting` (`plot_arm`, `plot_workspace`), `labkit.motion`.
        """),
        parameters(f"""
        robot = "planar3r_seed003"
        seed = 3            # random start/end configurations (two examples)
        duration = 4.0      # [s]
        output_dir = {out_default(LAB003, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np

        from labkit.kinematics import fk_position
        from labkit.motion import joint_trajectory
        from labkit.plotting import END_COLOR, START_COLOR, plot_arm, plot_workspace
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 003 task 4: plot manipulator")
        rng = np.random.default_rng(seed)
        limits = arm.joint_limits
        examples = [rng.uniform(limits[:, 0], limits[:, 1], size=(2, arm.n)) for _ in range(2)]
        """),
        md(r"""
        ## Figures 7 and 8: the initial and final configurations
        """),
        code(r"""
        q_a, q_b = examples[0]
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
        plot_arm(arm, q_a, ax=axes[0], color=START_COLOR, label="initial")
        plot_arm(arm, q_b, ax=axes[1], color=END_COLOR, label="final")
        for ax, t in zip(axes, ["Figure 7: initial configuration", "Figure 8: final configuration"]):
            ax.set_title(t)
            ax.legend()
        fig.tight_layout()
        plt.show()
        """),
        md(r"""
        ## Figures 9 and 10: trajectories within the workspace
        """),
        code(r"""
        fig, axes = plt.subplots(1, 2, figsize=(12, 5.4))
        trajs = []
        for k, (ax, (q_start, q_end)) in enumerate(zip(axes, examples)):
            traj = joint_trajectory(q_start, q_end, duration, robot=arm, dt=0.05)
            trajs.append(traj)
            plot_workspace(arm, ax=ax, n=8000, color="0.7")
            path = fk_position(arm, traj.q) * 1e3
            ax.plot(path[:, 0], path[:, 1], "-", color="C0", lw=2, label="end-effector path")
            plot_arm(arm, traj.q[:: max(1, len(traj.t) // 6)], ax=ax)
            ax.plot(*path[0, :2], "o", color=START_COLOR, ms=9)
            ax.plot(*path[-1, :2], "o", color=END_COLOR, ms=9)
            ax.set_title(f"Figure {9 + k}: example {k + 1} (random start and end)")
            ax.legend(loc="lower left", fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "trajectories_within_workspace.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Checks

        No numbers are published. Checked: the first and last configurations drawn are red and
        green, the path starts and ends at FK of the start/end configurations (1e-12 mm), and the
        random configurations and the trajectories between them respect the joint limits.
        """),
        code(r"""
        link_lines = [ln for ln in axes[0].lines if ln.get_gid() == "arm-links"]
        from matplotlib.colors import to_rgba
        checks.check("start configuration drawn red", float(to_rgba(link_lines[0].get_color()) == to_rgba(START_COLOR)), 1.0, tol=0,
                     note="seed: start red")
        checks.check("end configuration drawn green", float(to_rgba(link_lines[-1].get_color()) == to_rgba(END_COLOR)), 1.0, tol=0,
                     note="seed: end green")
        for k, traj in enumerate(trajs):
            checks.check(f"example {k + 1}: path ends = FK(start), FK(end) [m]",
                         fk_position(arm, traj.q[[0, -1]]), fk_position(arm, examples[k]), tol=1e-12, note="")
            checks.check(f"example {k + 1}: inside the joint limits", float(arm.within_limits(traj.q).all()), 1.0, tol=0, note="+-90 deg")
        checks.assert_all()
        """),
    ]


def seed003_via_points():
    name = "05_via_points_on_arm"
    return name, "Seed 003, task 5: via-point trajectory (5 via points) run on the arm", [
        md(rf"""
        # Via-point trajectory through five Cartesian points, run on the arm

        Reproduces seed {SEED003}, **task 5 (section II.G)** and the runs on the simulated and
        real robot (figures 11-14): five via points in the Cartesian workspace, IK at each (one
        consistent elbow branch), a joint-space cubic spline through them (continuous velocity
        and acceleration), the end-effector path in Cartesian space and the joint trajectories.
        The Gazebo run is replaced by the built-in simulated arm (`port = "sim://..."`; a real
        board with `-p port /dev/ttyACM0`): the trajectory is streamed as polynomial segments and
        the joints are read back while it runs.
        Library: `labkit.kinematics`, `labkit.motion.via_trajectory`, `labkit.arm.Arm`, `labkit.plotting`.
        """),
        parameters(f"""
        robot = "planar3r_seed003"
        port = "sim://planar3r_seed003?clock=lockstep&seed=0"  # the simulated arm; a real board: /dev/ttyACM0
        via_points = [[0.26, 0.02, 1.05], [0.27, 0.08, 1.05], [0.26, 0.15, 1.05], [0.23, 0.21, 1.05], [0.18, 0.27, 1.05]]  # (x, y [m], phi [rad])
        segment_duration = 1.0      # between via points [s]
        method = "spline"           # "spline" (continuous acceleration) or "via_cubic" (continuous velocity)
        dt = 0.05                   # sample step [s]
        output_dir = {out_default(LAB003, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.arm import Arm
        from labkit.kinematics import fk, fk_position, ik, ik_all
        from labkit.motion import via_trajectory
        from labkit.plotting import plot_arm, plot_time_series, plot_workspace
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        model = Robot.load(robot)
        checks = Checks("Seed 003 task 5: via points on the arm")
        V = np.asarray(via_points, float)
        first = ik_all(model, V[0])
        branch = first.branches[int(np.argmax(first.valid))]  # first valid branch at the first via point, kept for all
        Q = ik(model, V, branch=branch)
        traj = via_trajectory(Q, durations=segment_duration, method=method, robot=model, dt=dt)
        t_via = np.arange(len(V)) * segment_duration
        pd.DataFrame(np.degrees(Q), columns=[f"{n} [deg]" for n in model.joint_names],
                     index=pd.Index(t_via, name="t [s]")).assign(**{"x [mm]": V[:, 0] * 1e3, "y [mm]": V[:, 1] * 1e3,
                                                                    "phi [deg]": np.degrees(V[:, 2])}).round(2)
        """),
        md(r"""
        ## The end-effector path and the joint trajectories
        """),
        code(r"""
        path = fk_position(model, traj.q) * 1e3
        fig = plt.figure(figsize=(13, 4.8))
        ax = fig.add_subplot(1, 3, 1)
        plot_workspace(model, ax=ax, n=8000, color="0.85")
        ax.plot(path[:, 0], path[:, 1], "-", color="C0", lw=2, label="end-effector path")
        ax.plot(V[:, 0] * 1e3, V[:, 1] * 1e3, "s", color="k", ms=6, label="via points")
        plot_arm(model, Q[[0, -1]], ax=ax)
        ax.set_xlim(-50, 360)
        ax.set_ylim(-120, 300)
        ax.legend(fontsize=7, loc="lower left")
        ax.set_title(f"via points ({method}, {branch})")
        plot_time_series(traj, "q", ax=fig.add_subplot(1, 3, 2))
        plot_time_series(traj, "qd", ax=fig.add_subplot(1, 3, 3))
        fig.tight_layout()
        fig.savefig(out / "via_points.png", dpi=110)
        plt.show()
        """),
        md(r"""
        ## Run on the arm

        The trajectory streams as one cubic segment per sample interval; after each segment is
        queued the joints are read back, so the measured path is sampled while the arm moves.
        """),
        code(r"""
        samples = []
        with Arm(port, robot=robot) as arm:
            arm.set_host_timeout(5.0)
            arm.move_joints(traj.q[0], wait=True)

            def record(done, total):
                st = arm.status()
                samples.append((st.t, *arm.read_joints()))

            t0 = arm.status().t
            report = arm.run_trajectory(traj, progress=record, wait=True)
            q_final = arm.wait_settled(traj.q[-1], tol=np.radians(2.0))
            arm.set_host_timeout(0.5)
        measured = pd.DataFrame(samples, columns=["t", *[f"q_{n}" for n in model.joint_names]])
        measured["t"] -= t0
        measured.to_csv(out / "measured_joints.csv", index=False)
        q_meas = measured.iloc[:, 1:].to_numpy()
        # the command the arm was following when each sample was read:
        q_plan_at = np.column_stack([np.interp(measured.t, traj.t, traj.q[:, j]) for j in range(model.n)])
        print(report)
        print(f"{len(measured)} samples while streaming; final tool error "
              f"{np.linalg.norm(fk_position(model, q_final) - fk_position(model, traj.q[-1])) * 1e3:.1f} mm")
        """),
        code(r"""
        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
        for j, name in enumerate(model.joint_names):
            axes[0].plot(traj.t, np.degrees(traj.q[:, j]), "-", color=f"C{j}", label=f"{name} planned")
            axes[0].plot(measured.t, np.degrees(q_meas[:, j]), ".", color=f"C{j}", ms=3, label=f"{name} measured")
        axes[0].set(xlabel="t [s]", ylabel="joint [deg]", title="planned vs measured joints")
        axes[0].legend(fontsize=7, ncol=2)
        meas_xy = fk_position(model, q_meas) * 1e3
        axes[1].plot(path[:, 0], path[:, 1], "-", label="planned")
        axes[1].plot(meas_xy[:, 0], meas_xy[:, 1], ".", ms=4, label="measured (joint feedback)")
        axes[1].plot(V[:, 0] * 1e3, V[:, 1] * 1e3, "ks", ms=5, label="via points")
        axes[1].set(xlabel="x [mm]", ylabel="y [mm]", title="end-effector path")
        axes[1].set_aspect("equal", adjustable="datalim")
        axes[1].legend(fontsize=7)
        for ax in axes:
            ax.grid(True)
        fig.tight_layout()
        plt.show()
        """),
        md(r"""
        ## Checks

        No numbers are published. Checked: FK at the via times returns every via point
        (1e-9 m / rad), velocity and acceleration are continuous at the interior via points (a
        cubic spline; 1e-9), the arm starts and ends at rest, and on the arm the stream never ran
        dry and the final tool position is within 10 mm (simulated servo zero offsets ~1 deg).
        """),
        code(r"""
        idx = np.searchsorted(traj.t, t_via - 1e-9)
        T_via = fk(model, traj.q[idx])
        via_xyphi = np.c_[T_via[:, 0, 3], T_via[:, 1, 3], np.arctan2(T_via[:, 1, 0], T_via[:, 0, 0])]
        checks.check("FK at the via times - via points", via_xyphi, V, tol=1e-9, note="x, y [m], phi [rad]")
        law = traj.law
        tv = t_via[1:-1]
        if method == "spline":
            jump_a = np.abs(law.acceleration(tv + 1e-9) - law.acceleration(tv - 1e-9)).max()
            checks.check("acceleration continuous at the via points [rad/s^2]", jump_a, 0.0, tol=1e-6, note="cubic spline")
        jump_v = np.abs(law.velocity(tv + 1e-9) - law.velocity(tv - 1e-9)).max()
        checks.check("velocity continuous at the via points [rad/s]", jump_v, 0.0, tol=1e-6, note="")
        checks.check("rest at start and end [rad/s]", traj.qd[[0, -1]], np.zeros((2, 3)), tol=1e-9, note="clamped ends")
        checks.check("stream underruns", report.underruns, 0, tol=0, note="queue kept fed")
        checks.check("final tool position on the arm [mm]",
                     np.linalg.norm(fk_position(model, q_final) - fk_position(model, traj.q[-1])) * 1e3, 0.0, tol=10.0,
                     note="servo zero offsets ~1 deg")
        checks.assert_all()
        """),
    ]


# --------------------------------------------------------------------------------------------
# seed 004: planar 3R IK and trajectory planning (MEM675)
# --------------------------------------------------------------------------------------------


def seed004_ik():
    name = "01_ik_elbow_minus"
    return name, "Seed 004, parts A-C: planar 3R IK (elbow minus), verification plot, plotManipulator", [
        md(rf"""
        # Planar 3R inverse kinematics (elbow minus) and the manipulator plot

        Reproduces seed {SEED004}, **parts A, B and C**: the planar 3R arm ($L_1 = 0.2$,
        $L_2 = 0.15$, $L_3 = 0.12$ m, A.1), the analytic IK of A.2 - joint 3 location, $\theta_2$ by
        the cosine law, $\theta_1$ from the 2 x 2 linear system, $\theta_3 = \phi_e - \theta_1 - \theta_2$ -,
        the verification plot of A.4 (the end effector, a red dot, must land on $(x_e, y_e)$ with
        orientation $\phi_e$), the `IK.m` function of part B (elbow minus) and `plotManipulator.m` of
        part C. The handout gives no numeric target: the parameters hold one.
        Library: `labkit.kinematics.ik(..., branch="elbow_minus")`, `labkit.plotting.plot_arm`.
        """),
        parameters(f"""
        robot = "planar3r_seed004"
        xe = 0.30          # [m]
        ye = 0.20          # [m]
        phie = 0.7854      # [rad]
        output_dir = {out_default(LAB004, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        import pandas as pd

        from labkit.kinematics import fk, fk_frames, ik, ik_all
        from labkit.plotting import plot_arm
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 004 parts A-C: IK elbow minus")
        L1, L2, L3 = (float(a) for a in arm.a)
        arm.dh_table()
        """),
        md(r"""
        ## Part B: `q = IK(xe, ye, phie, L1, L2, L3)`, elbow minus

        labkit's planar solver gives both branches; "elbow minus" ($\theta_2 = -\operatorname{atan2}
        (\sqrt{1 - c_2^2}, c_2) \le 0$) is an alias of its `elbow_up` branch.
        """),
        code(r"""
        q = ik(arm, [xe, ye, phie], branch="elbow_minus")
        both = ik_all(arm, [xe, ye, phie])
        print("elbow minus q [rad]:", np.round(q, 6), " [deg]:", np.round(np.degrees(q), 3))
        both.to_dataframe().round(4)
        """),
        md(r"""
        ## A.2 step by step, as the handout derives it

        The handout's own steps evaluated at the target (they are the published derivation under
        test; the solver above is labkit's):
        """),
        code(r"""
        x3, y3 = xe - L3 * np.cos(phie), ye - L3 * np.sin(phie)                       # step 1
        cos_t2 = (x3**2 + y3**2 - L1**2 - L2**2) / (2 * L1 * L2)                      # step 2
        t2 = -np.arctan2(np.sqrt(1 - cos_t2**2), cos_t2)                              # elbow minus
        M = np.array([[L1 + L2 * np.cos(t2), -L2 * np.sin(t2)], [L2 * np.sin(t2), L1 + L2 * np.cos(t2)]])
        c1, s1 = np.linalg.solve(M, [x3, y3])                                          # step 3
        t1 = np.arctan2(s1, c1)
        t3 = phie - t1 - t2                                                            # step 4
        steps = pd.Series({"x3 [m]": x3, "y3 [m]": y3, "cos theta2": cos_t2, "theta1 [rad]": t1, "theta2 [rad]": t2,
                           "theta3 [rad]": t3, "|(c1, s1)| (must be 1)": np.hypot(c1, s1)})
        steps.round(6).to_frame("A.2")
        """),
        md(r"""
        ## A.4: the verification plot, and part C: `plotManipulator(q, L1, L2, L3)`
        """),
        code(r"""
        frames = fk_frames(arm, q)
        tip = frames[-1, :2, 3]
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
        plot_arm(arm, q, ax=axes[0], units="m", label="elbow minus")
        axes[0].plot(tip[0], tip[1], "o", color="red", ms=8, label="end effector (FK)")
        axes[0].plot(xe, ye, "+", color="k", ms=14, label="target (xe, ye)")
        axes[0].set_title("A.4 verification: the red dot must sit on the target")
        axes[0].legend(fontsize=8)
        plot_arm(arm, both.q, ax=axes[1], units="m", start_end=False)
        axes[1].set_title("both branches (elbow minus / elbow plus)")
        fig.tight_layout()
        fig.savefig(out / "ik_verification.png", dpi=110)
        plt.show()
        T = fk(arm, q)
        reached = np.array([T[0, 3], T[1, 3], np.arctan2(T[1, 0], T[0, 0])])
        print("FK of the IK solution: x, y [m], phi [rad] =", np.round(reached, 6))
        """),
        md(r"""
        ## Checks

        The handout publishes no numbers, only the test "the red dot is at $(x_e, y_e)$ with
        orientation $\phi_e$": FK of the elbow-minus solution must return the target (1e-12),
        $\theta_2 \le 0$ on elbow minus, the handout's step-by-step derivation must give the same
        angles (1e-12 rad) with $(\cos\theta_1, \sin\theta_1)$ of unit length, and both branches reach.
        """),
        code(r"""
        checks.check("FK(IK) - target (A.4)", reached, [xe, ye, phie], tol=1e-12, note="x, y [m], phi [rad]")
        checks.check("elbow minus: theta2 <= 0", float(q[1] <= 0), 1.0, tol=0, note="part B")
        checks.check("A.2 steps - labkit [rad]", [t1, t2, t3], q, tol=1e-12, note="handout's derivation")
        checks.check("|(cos theta1, sin theta1)| from the 2x2 system", np.hypot(c1, s1), 1.0, tol=1e-12, note="step 3")
        checks.check("both branches reachable", float(both.reachable.all()), 1.0, tol=0, note="elbow minus and plus")
        checks.assert_all()
        """),
    ]


def seed004_arc():
    name = "02_arc_trajectory_animation"
    return name, "Seed 004, parts D-E: 90-degree arc trajectory and the animation (in place of Simscape)", [
        md(rf"""
        # The 90° arc: manipulator configurations, joint angles, and the animation

        Reproduces seed {SEED004}, **part D** (the end effector follows a 90° arc of the circle
        with centre $(x_R, y_R) = (0.1, 0.25)$ m and radius $R = 0.25$ m during 0-2 s: left figure
        the manipulator configurations, right figure the joint angles) and **part E** (the
        Simscape simulation of the same joint angles), replaced here by a matplotlib animation
        embedded in the report (jshtml).

        The handout does not say where on the circle the quarter starts nor the tool orientation.
        Most of that circle is out of reach: its far side is $\lVert(0.1, 0.25)\rVert + 0.25 = 0.519$ m from the
        base, the arm reaches $0.47$ m. The default here is the quarter from $-90^\circ$ (the point
        (0.1, 0)) to $0^\circ$ ((0.35, 0.25)), the tool pointing radially outwards, elbow minus.
        Library: `labkit.motion` (`arc`, `cartesian_trajectory`), `labkit.plotting` (`plot_arm`, `animate_arm`).
        """),
        parameters(f"""
        robot = "planar3r_seed004"
        center = [0.1, 0.25]        # (xR, yR) [m]
        radius = 0.25               # R [m]
        start_deg = -90.0           # where the quarter starts on the circle [deg]
        sweep_deg = 90.0            # the arc [deg]
        phi_deg = [-90.0, 0.0]      # tool orientation at start and end [deg] (radially outwards)
        duration = 2.0              # [s]
        dt = 0.02                   # [s]
        max_frames = 40             # animation frames
        output_dir = {out_default(LAB004, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        from IPython.display import HTML

        from labkit.exceptions import UnreachableError
        from labkit.kinematics import fk_position
        from labkit.motion import arc, cartesian_trajectory
        from labkit.plotting import animate_arm, plot_arm, plot_time_series
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 004 parts D-E: arc")
        center = np.asarray(center, float)
        path = arc(center, radius, np.radians(start_deg), np.radians(sweep_deg))
        traj = cartesian_trajectory(arm, path, duration, dt=dt, orientation=np.radians(phi_deg), branch="elbow_minus")
        reach = float(np.sum(arm.a))
        print(f"{len(traj.t)} samples over {duration:g} s; reach {reach:.2f} m, far side of the circle "
              f"{np.linalg.norm(center) + radius:.3f} m from the base")
        """),
        md(r"""
        ## Part D: manipulator configurations (left) and joint angles (right)
        """),
        code(r"""
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
        circle = center + radius * np.c_[np.cos(np.linspace(0, 2 * np.pi, 200)), np.sin(np.linspace(0, 2 * np.pi, 200))]
        axes[0].plot(circle[:, 0], circle[:, 1], ":", color="0.6", label="the full circle")
        plot_arm(arm, traj.q[:: max(1, len(traj.t) // 10)], ax=axes[0], units="m")
        axes[0].plot(traj.x[:, 0], traj.x[:, 1], "-", color="C1", lw=2, label="end-effector arc")
        axes[0].legend(fontsize=8, loc="upper left")
        axes[0].set_title("manipulator configuration trajectory")
        plot_time_series(traj, "q", ax=axes[1], degrees=False)
        axes[1].set_title("joint angles, 0-2 s")
        fig.tight_layout()
        fig.savefig(out / "arc.png", dpi=110)
        plt.show()
        traj.to_dataframe().iloc[:: len(traj.t) // 5].round(4)
        """),
        md(r"""
        ## Why the orientation must be chosen: holding $\phi = 90^\circ$ on the same arc fails

        labkit names the first unreachable sample, its time and by how much:
        """),
        code(r"""
        try:
            cartesian_trajectory(arm, path, duration, dt=0.05, orientation=np.pi / 2, branch="elbow_minus")
            held_phi_error = None
        except UnreachableError as exc:
            held_phi_error = exc
            print(exc)
        """),
        md(r"""
        ## Part E: the simulation, as an animation (in place of Simscape)

        The joint angles `theta1dsim`, `theta2dsim`, `theta3dsim` of the handout are `traj.q`;
        the animation draws the arm at each time with the tool's trail (start ghost red, end green).
        """),
        code(r"""
        anim = animate_arm(arm, traj, max_frames=max_frames, units="m")
        plt.close(anim._fig)
        HTML(anim.to_jshtml())
        """),
        md(r"""
        ## Checks

        Numbers that follow from the handout: every sample on the circle (radius 0.25 m, 1e-9 m),
        the swept angle (90°), the time span (0-2 s), elbow minus throughout ($\theta_2 < 0$), and
        the reach argument (far side 0.519 m > 0.47 m).
        """),
        code(r"""
        r = np.linalg.norm(traj.x[:, :2] - center, axis=1)
        swept = np.degrees(np.ptp(np.unwrap(np.arctan2(traj.x[:, 1] - center[1], traj.x[:, 0] - center[0]))))
        checks.check("distance from the centre [m] (part D)", r, np.full_like(r, radius), tol=1e-9, note="R = 0.25")
        checks.check("swept angle [deg] (part D)", swept, sweep_deg, tol=1e-9, note="90 degree arc")
        checks.check("time span [s] (part D)", [traj.t[0], traj.t[-1]], [0.0, duration], tol=1e-12, note="0-2 s")
        checks.check("elbow minus throughout", float((traj.q[:, 1] < 0).all()), 1.0, tol=0, note="theta2 < 0")
        checks.check("tool on the arc (FK) [m]", fk_position(arm, traj.q)[:, :2], traj.x[:, :2], tol=1e-9, note="IK at every sample")
        checks.check("far side of the circle beyond the reach [m]", np.linalg.norm(center) + radius - reach, 0.0493, tol=5e-4,
                     note="0.519 - 0.47")
        checks.check("held phi = 90 deg is unreachable", float(held_phi_error is not None), 1.0, tol=0, note="orientation matters")
        checks.assert_all()
        """),
    ]


def seed004_line():
    name = "03_straight_line"
    return name, "Seed 004, part F: a straight line of the user's choice", [
        md(rf"""
        # A straight-line trajectory of your choice

        Reproduces seed {SEED004}, **part F** ("create another trajectory that makes the end
        effector follow a straight line that you determine; repeat parts C and D"): the line's
        endpoints, orientation and duration are parameters (`labkit run ... -p line_start
        "[0.3, -0.1]"`), with the manipulator configurations, the joint angles and the animation.
        Library: `labkit.motion` (`line`, `cartesian_trajectory`), `labkit.plotting` (`plot_arm`, `animate_arm`).
        """),
        parameters(f"""
        robot = "planar3r_seed004"
        line_start = [0.35, -0.10]  # [m]
        line_end = [0.15, 0.30]     # [m]
        phi_deg = [0.0, 60.0]       # tool orientation at start and end [deg] (one value: held)
        duration = 2.0              # [s]
        dt = 0.02                   # [s]
        branch = "elbow_minus"      # as in part B
        max_frames = 30             # animation frames
        output_dir = {out_default(LAB004, name)}
        """),
        code(r"""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        from IPython.display import HTML

        from labkit.kinematics import fk_position
        from labkit.motion import cartesian_trajectory, line
        from labkit.plotting import animate_arm, plot_arm, plot_time_series
        from labkit.reports import Checks
        from labkit.robot import Robot

        out = Path(output_dir)
        out.mkdir(parents=True, exist_ok=True)
        arm = Robot.load(robot)
        checks = Checks("Seed 004 part F: straight line")
        p0, p1 = np.asarray(line_start, float), np.asarray(line_end, float)
        traj = cartesian_trajectory(arm, line(p0, p1), duration, dt=dt, orientation=np.radians(phi_deg), branch=branch)
        print(f"{len(traj.t)} samples, line length {np.linalg.norm(p1 - p0):.3f} m, "
              f"peak tool speed {np.linalg.norm(traj.xd[:, :2], axis=1).max():.3f} m/s")
        """),
        code(r"""
        fig, axes = plt.subplots(1, 3, figsize=(14, 4.4))
        plot_arm(arm, traj.q[:: max(1, len(traj.t) // 10)], ax=axes[0], units="m")
        axes[0].plot(traj.x[:, 0], traj.x[:, 1], "-", color="C1", lw=2, label="end-effector line")
        axes[0].legend(fontsize=8)
        axes[0].set_title("manipulator configuration trajectory")
        plot_time_series(traj, "q", ax=axes[1], degrees=False)
        axes[1].set_title("joint angles")
        plot_time_series(traj, "qd", ax=axes[2], degrees=False)
        axes[2].set_title("joint rates")
        fig.tight_layout()
        fig.savefig(out / "line.png", dpi=110)
        plt.show()
        """),
        code(r"""
        anim = animate_arm(arm, traj, max_frames=max_frames, units="m")
        plt.close(anim._fig)
        HTML(anim.to_jshtml())
        """),
        md(r"""
        ## Checks

        The line is the user's, so the checks are geometric: every sample on the segment
        (distance to the line 1e-9 m), the endpoints, the orientation at both ends, and FK of
        the joint samples on the path (1e-9 m).
        """),
        code(r"""
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        d = traj.x[:, :2] - p0
        off_line = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
        phis = np.atleast_1d(np.radians(phi_deg))
        checks.check("distance from the line [m]", off_line.max(), 0.0, tol=1e-9, note="straight")
        checks.check("endpoints [m]", traj.x[[0, -1], :2], [p0, p1], tol=1e-12, note="")
        checks.check("orientation at the ends [rad]", traj.x[[0, -1], 2], [phis[0], phis[-1]], tol=1e-12, note="")
        checks.check("FK of the joint samples on the path [m]", fk_position(arm, traj.q)[:, :2], traj.x[:, :2], tol=1e-9, note="")
        checks.assert_all()
        """),
    ]


NOTEBOOKS = {
    f"{LAB000}/01_link_measurement_dh.ipynb": seed000_dh,
    f"{LAB000}/02_fk_check_tables.ipynb": seed000_fk_tables,
    f"{LAB000}/03_ik_table4.ipynb": seed000_ik_table4,
    f"{LAB000}/04_ik_linear_motion.ipynb": seed000_linear_motion,
    f"{LAB000}/05_cubic_trajectory.ipynb": seed000_cubic,
    f"{LAB000}/06_pick_and_place.ipynb": seed000_pick_place,
    f"{LAB000}/07_calibration.ipynb": seed000_calibration,
    f"{LAB003}/01_fk_workspace.ipynb": seed003_fk_workspace,
    f"{LAB003}/02_cubic_joint_trajectories.ipynb": seed003_cubic,
    f"{LAB003}/03_ik_orientation_click.ipynb": seed003_ik_click,
    f"{LAB003}/04_plot_manipulator.ipynb": seed003_plot_manipulator,
    f"{LAB003}/05_via_points_on_arm.ipynb": seed003_via_points,
    f"{LAB004}/01_ik_elbow_minus.ipynb": seed004_ik,
    f"{LAB004}/02_arc_trajectory_animation.ipynb": seed004_arc,
    f"{LAB004}/03_straight_line.ipynb": seed004_line,
}


def main(argv=None):
    make_notebooks.main(argv, NOTEBOOKS)


if __name__ == "__main__":
    main()
