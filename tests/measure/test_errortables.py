"""Tests of labkit.measure error tables: FK/IK error tables, styled output, published-table audit."""

import html as _html
import math
import re

import numpy as np
import pandas as pd
import pytest

from labkit.robot import Robot
from labkit.measure import (
    audit_published,
    decimals_for_resolution,
    error_table,
    fk_error_table,
    ik_error_table,
    load_published,
)
from labkit.data import measurement_file
from labkit.reports import error_report_table
from labkit.exceptions import MeasurementError
from labkit.measure import MeasurementLog

FK_SEED = measurement_file("seed000_fk_tables1-3.csv")
IK_SEED = measurement_file("seed000_ik_table4.csv")
PUBLISHED = measurement_file("seed000_published_calculated.csv")

# seed 000 tables 1-3 as printed: pose -> measured (mean, half range) per axis [m]
SEED_MEASURED = {
    "t1_j1_5deg": ((0.28, 0.02), (0.065, 0.05), (0.00, 0.01)),
    "t2_j2_45deg": ((0.22, 0.01), (0.00, 0.01), (-0.17, 0.02)),
    "t3_j3_80deg": ((0.12, 0.01), (0.00, 0.01), (0.17, 0.01)),
}


@pytest.fixture(scope="module")
def arm():
    return Robot.load("arduino_arm_3dof")


def test_fk_table_reproduces_seed_means_and_ranges(arm):
    table = fk_error_table(arm, FK_SEED).table
    assert len(table) == 45
    assert set(table["n"]) == {3}
    for pose, axes in SEED_MEASURED.items():
        for k, ax in enumerate("xyz"):
            row = table[(table["pose_id"] == pose) & (table["quantity"] == ax)].iloc[0]
            assert row["mean"] == pytest.approx(axes[k][0])
            assert row["half_range"] == pytest.approx(axes[k][1])
            assert math.isnan(row["std"])  # raw readings lost: not invented


def test_fk_table_errors_against_model(arm):
    table = fk_error_table(arm, FK_SEED).table.set_index(["pose_id", "quantity"])
    # model: x = cos(q1) (L1 cos q2 + L2 cos(q2 - q3)) ... at q1 = 5 deg: 0.274 cos 5deg
    row = table.loc[("t1_j1_5deg", "x")]
    assert row["calculated"] == pytest.approx(0.274 * math.cos(math.radians(5)), abs=1e-12)
    assert row["error"] == pytest.approx(0.28 - 0.274 * math.cos(math.radians(5)))
    assert row["abs_error"] == pytest.approx(abs(row["error"]))
    assert row["rel_error"] == pytest.approx(abs(row["error"]) / row["calculated"])
    # uncertainty = resolution (+) half range in quadrature
    assert row["uncertainty"] == pytest.approx(math.hypot(0.0005, 0.02))
    assert bool(row["inside"]) is True
    # table 1, 45 deg, x: 0.180 measured vs 0.1937 calculated, +-0.01 -> outside
    assert bool(table.loc[("t1_j1_45deg", "x"), "inside"]) is False
    # relative error undefined where the calculated value is (near) zero
    assert math.isnan(table.loc[("t1_j1_90deg", "x"), "rel_error"])


def test_summary_rows(arm):
    result = error_table(arm, FK_SEED)
    t = result.table
    for ax in "xyz":
        e = t.loc[t["quantity"] == ax, "error"].to_numpy()
        s = result.summary.loc[ax]
        assert s["rms_error"] == pytest.approx(np.sqrt(np.mean(e ** 2)))
        assert s["max_abs_error"] == pytest.approx(np.abs(e).max())
        assert s["n_poses"] == 15
    wide = result.wide()
    assert list(wide.index[-2:]) == ["RMS", "max abs. error"]
    assert wide.loc["RMS", ("x [m]", "error")] == pytest.approx(result.summary.loc["x", "rms_error"])
    assert wide.loc["t1_j1_5deg", ("y [m]", "measured")] == pytest.approx(0.065)


def test_combine_rule_sum_is_wider(arm):
    q = error_table(arm, FK_SEED, combine="quadrature").table
    s = error_table(arm, FK_SEED, combine="sum").table
    assert np.all(s["uncertainty"] >= q["uncertainty"])
    assert s["inside"].sum() >= q["inside"].sum()
    with pytest.raises(MeasurementError, match="quadrature"):
        error_table(arm, FK_SEED, combine="max")


def test_ik_table_seed_table4(arm):
    result = ik_error_table(arm, IK_SEED)
    t = result.table.set_index(["pose_id", "quantity"])
    assert t.loc[("t4_row1", "theta2"), "calculated"] == pytest.approx(113.86, abs=0.01)
    assert t.loc[("t4_row5", "theta1"), "calculated"] == pytest.approx(
        math.degrees(math.atan2(0.25, -0.10)))
    assert t.loc[("t4_row3", "theta1"), "mean"] == 138
    assert t.loc[("t4_row3", "theta1"), "half_range"] == 2
    # row 6, theta3: 49 measured vs 131.3 calculated (the protractor read the supplement)
    assert t.loc[("t4_row6", "theta3"), "error"] == pytest.approx(49 - 131.303, abs=0.01)
    assert not t.loc[("t4_row6", "theta3"), "inside"]
    assert t.loc[("t4_row1", "theta1"), "inside"]
    assert set(t["unit"]) == {"deg"}


def test_raw_readings_spread_and_fk_of_logged_session(tmp_path, arm):
    path = tmp_path / "s.csv"
    q = [0.3, 0.4, 0.5]
    x_model = arm.fk(q)[0, 3]
    readings = [1000 * x_model + d for d in (-1.0, 0.5, 2.0)]
    with MeasurementLog(arm, path) as log:
        for v in readings:
            log.record("p", "x", v, unit="mm", instrument="ruler", resolution=0.5, commanded=q)
        log.record("p", "theta2", 23.0, unit="deg", instrument="protractor", resolution=0.5, commanded=q)
    t = error_table(None, path).table.set_index("quantity")
    assert t.loc["x", "unit"] == "mm"
    assert t.loc["x", "calculated"] == pytest.approx(1000 * x_model)
    assert t.loc["x", "mean"] == pytest.approx(np.mean(readings))
    assert t.loc["x", "half_range"] == pytest.approx(1.5)
    assert t.loc["x", "std"] == pytest.approx(np.std(readings, ddof=1))
    assert t.loc["x", "n"] == 3
    # theta_i with commanded joints compares with the commanded value
    assert t.loc["theta2", "calculated"] == pytest.approx(math.degrees(0.4))


def test_angle_error_wraps(tmp_path, arm):
    path = tmp_path / "w.csv"
    with MeasurementLog(arm, path) as log:
        log.record("p", "theta1", -179.0, unit="deg", instrument="protractor", resolution=0.5,
                   commanded=[math.radians(179), 0, 0])
    t = error_table(None, path).table
    assert t.loc[0, "error"] == pytest.approx(2.0)


def test_pose_without_command_names_row(tmp_path, arm):
    path = tmp_path / "bad.csv"
    path.write_text("pose_id,quantity,value,unit,resolution,commanded\n"
                    "p1,x,0.27,m,0.0005,0.1 0 0\n"
                    "p2,x,0.27,m,0.0005,\n")
    with pytest.raises(MeasurementError, match="row 3, column 'commanded'"):
        error_table(arm, path)
    path.write_text("pose_id,quantity,value,unit,resolution,commanded\n"
                    "p1,theta4,0.27,rad,0.0005,0.1 0 0\n")
    with pytest.raises(MeasurementError, match="row 2, column 'quantity'"):
        error_table(arm, path)


def test_summary_row_mixed_with_readings_is_rejected(tmp_path, arm):
    path = tmp_path / "mix.csv"
    path.write_text("pose_id,quantity,value,unit,resolution,half_range,n_readings,commanded\n"
                    "p1,x,0.27,m,0.0005,0.01,3,0.1 0 0\n"
                    "p1,x,0.26,m,0.0005,,,0.1 0 0\n")
    with pytest.raises(MeasurementError, match="column 'half_range'"):
        error_table(arm, path)


def test_decimals_from_resolution():
    assert decimals_for_resolution(0.0005) == 4
    assert decimals_for_resolution(0.5) == 1
    assert decimals_for_resolution(0.05) == 2
    assert decimals_for_resolution(1.0) == 0
    assert decimals_for_resolution(5.0) == 0
    with pytest.raises(MeasurementError):
        decimals_for_resolution(0.0)


def _html_cells(html):
    """(text, style or None) of every body cell of an HTML table, row by row."""
    return [[(_html.unescape(text), style) for style, text in re.findall(r'<td[^>]*?(?: style="([^"]*)")?>(.*?)</td>', row)]
            for row in re.findall(r"<tr>(.*?)</tr>", html.split("</thead>", 1)[1])]


@pytest.mark.parametrize("seed", [FK_SEED, IK_SEED])
def test_error_table_prints_what_the_report_prints(arm, seed):
    """to_html, to_latex and style show the cells and headers of the report's error table, nothing else."""
    result = error_table(arm, seed, branch="elbow_up")
    report = error_report_table(result)  # what a lab report shows (labkit.reports)
    html = result.to_html()
    assert re.findall(r"<th class=\"[^\"]*\">(.*?)</th>", html) == [_html.escape(h) for h in report.header]
    cells = _html_cells(html)
    assert [[text for text, _ in row] for row in cells] == [list(r) for r in report.rows]
    assert result.to_latex().replace(r"\cellcolor[HTML]{F8C4C4} ", "") == report.to_latex()
    styler = result.style()
    assert styler.data.values.tolist() == [list(r) for r in report.rows]
    assert re.findall(r'<th [^>]*class="col_heading[^"]*"[^>]*>(.*?)</th>', styler.to_html()) == list(report.header)
    assert not re.search(r"\b(True|False|NaN|nan)\b", html)


def test_out_of_uncertainty_readings_are_highlighted(arm):
    result = error_table(arm, IK_SEED, branch="elbow_up")
    table = result.table
    html = result.to_html(pose="pose_id")
    cells = _html_cells(html)
    marked = {(k, j) for k, row in enumerate(cells) for j, (_, style) in enumerate(row) if style}
    # independent of the inside column: |mean - calculated| against U = sqrt(resolution^2 + half_range^2)
    outside = np.abs(table["mean"] - table["calculated"]) > np.hypot(table["resolution"], table["half_range"]) * (1 + 1e-9)
    assert marked == {(k, j) for k in np.flatnonzero(outside) for j in (3, 5)}  # measured and error
    row5 = table.index[(table.pose_id == "t4_row5") & (table.quantity == "theta1")][0]
    row1 = table.index[(table.pose_id == "t4_row1") & (table.quantity == "theta1")][0]
    assert (row5, 5) in marked and (row1, 5) not in marked
    assert cells[row5][5][1] == "background-color: #f8c4c4"
    assert cells[row5][2][0] == "111.8" and cells[row5][5][0] == "-81.8"  # IK's 111.8 deg vs the read 30 deg
    tex = result.to_latex(caption="Table 4", pose="pose_id")
    assert "\\caption{Table 4}" in tex and "t4\\_row5" in tex
    assert tex.count("\\cellcolor[HTML]{F8C4C4}") == 2 * int(outside.sum())
    styler = result.style(highlight="background-color: yellow")
    styler._compute()
    assert {k for k, v in styler.ctx.items() if v} == marked
    assert result.to_latex(highlight="background-color: yellow").count("\\cellcolor{yellow}") == 2 * int(outside.sum())


def test_style_with_explicit_tolerance(arm):
    result = error_table(arm, FK_SEED)
    styler = result.style(tolerance=0.03)  # 30 mm
    styler._compute()
    n_bad = int((result.table["abs_error"] > 0.03).sum())
    assert sum(1 for props in styler.ctx.values() if props) == 2 * n_bad
    assert n_bad == 2  # t1 5deg y (41 mm), t3 5deg x (33 mm)
    flagged = result.table[result.flagged(0.03)]
    assert set(zip(flagged.pose_id, flagged.quantity)) == {("t1_j1_5deg", "y"), ("t3_j3_5deg", "x")}
    ik = error_table(arm, IK_SEED, branch="elbow_up")
    per = ik.flagged({"theta1": np.radians(5.0)})  # a quantity not named is never flagged
    expected = (ik.table.quantity == "theta1") & (ik.table.error.abs() > 5.0)
    assert per.tolist() == expected.tolist() and per.sum() == 1  # t4_row5 (81.8 deg); row 6 is off by 3 deg


def test_error_table_output_says_what_it_expected(arm):
    from labkit.exceptions import OptionError

    result = error_table(arm, IK_SEED, branch="elbow_up")
    with pytest.raises(OptionError, match="expected options among tolerance, highlight, caption, unit, scale, pose, digits, got tol"):
        result.to_html(tol=0.1)
    with pytest.raises(OptionError, match="expected options among .* got escape"):
        result.to_latex(escape="latex")
    with pytest.raises(OptionError, match="tolerance names quantities 'x', which the table does not have .*theta1"):
        result.style(tolerance={"x": 0.01})
    with pytest.raises(OptionError, match="tolerance expects a non-negative number .* got -1 for 'theta1'"):
        result.to_html(tolerance=-1)
    with pytest.raises(OptionError, match="got 'a lot'"):
        result.report_table(tolerance="a lot")
    with pytest.raises(OptionError, match="escape expects None, 'html' or 'latex', got 'rtf'"):
        result.style(escape="rtf")
    with pytest.raises(OptionError, match="pose expects 'command' or 'pose_id', got 'row'"):
        result.to_html(pose="row")


def test_error_table_with_missing_values_prints_a_dash(arm):
    from labkit.measure import ErrorTable

    result = error_table(arm, IK_SEED, branch="elbow_up")
    table = result.table.copy()
    table.loc[0, ["mean", "error", "abs_error"]] = np.nan  # a reading that was never taken
    holed = ErrorTable(table=table, summary=result.summary)
    row = _html_cells(holed.to_html())[0]
    assert [text for text, _ in row][3:6] == ["–", "2.0", "–"] and row[6][0] == "yes"
    assert [list(r) for r in error_report_table(holed).rows] == [[t for t, _ in r] for r in _html_cells(holed.to_html())]


def test_no_negative_zero_in_report(arm):
    html = error_table(arm, FK_SEED).to_html()
    assert "-0.0000" not in html


# -- audit ---------------------------------------------------------------------------
EXPECTED_FLAGS = {
    ("table 3", "t3_j3_5deg"): ["x", "z"],     # 0.24 vs 0.273, 0.014 vs 0.0157
    ("table 3", "t3_j3_20deg"): ["z"],         # 0.060 vs 0.0616 (0.062 at 2 s.f.)
    ("table 4", "t4_row5"): ["theta1", "theta2", "theta3"],  # -45/105/82 vs 111.8/16.7/22.1
}


def test_audit_flags_exactly_the_wrong_rows(arm):
    audit = audit_published(arm, PUBLISHED)
    assert len(audit.cells) == 63
    assert audit.flagged_rows() == EXPECTED_FLAGS
    cells = audit.cells.set_index(["pose_id", "quantity"])
    assert cells.loc[("t3_j3_5deg", "x"), "recomputed"] == pytest.approx(0.2733, abs=1e-4)
    assert cells.loc[("t3_j3_5deg", "z"), "recomputed"] == pytest.approx(0.0157, abs=1e-4)
    assert cells.loc[("t3_j3_20deg", "z"), "recomputed"] == pytest.approx(0.0616, abs=1e-4)
    assert cells.loc[("t4_row5", "theta1"), "recomputed"] == pytest.approx(111.8014, abs=1e-3)
    assert cells.loc[("t3_j3_20deg", "z"), "tolerance"] == pytest.approx(0.0005)
    assert cells.loc[("t4_row1", "theta2"), "tolerance"] == pytest.approx(0.5)
    assert cells.loc[("t1_j1_5deg", "z"), "tolerance"] == pytest.approx(0.005)  # "0.00"


def test_audit_table4_against_cosine_rule(arm):
    """Every row of table 4 recomputed with the seed's own elbow-up formulas."""
    L1, L2 = 0.094, 0.180
    audit = audit_published(arm, PUBLISHED).cells
    t4 = audit[audit["table"] == "table 4"].set_index(["pose_id", "quantity"])
    published = load_published(PUBLISHED).set_index(["pose_id", "quantity"])
    for i in range(1, 7):
        X, Y, Z = published.loc[(f"t4_row{i}", "theta1"), "target"]
        Z = -Z
        d = math.sqrt(X * X + Y * Y + Z * Z)
        beta = math.acos((L1 ** 2 + d ** 2 - L2 ** 2) / (2 * L1 * d))
        k = math.acos((L1 ** 2 + L2 ** 2 - d ** 2) / (2 * L1 * L2))
        expect = [math.atan2(Y, X), math.atan2(Z, math.hypot(X, Y)) + beta, math.pi - k]
        for j in range(3):
            got = t4.loc[(f"t4_row{i}", f"theta{j + 1}"), "recomputed"]
            assert got == pytest.approx(math.degrees(expect[j]), abs=1e-6)


def test_audit_precision_rules(tmp_path, arm):
    path = tmp_path / "pub.csv"
    q = "0.0 0.0 0.3490658503988659"  # joint 3 at 20 deg: z = 0.0616
    path.write_text("pose_id,quantity,published,unit,precision,commanded\n"
                    f"a,z,0.062,m,2sf,{q}\n"
                    f"b,z,0.06,m,1sf,{q}\n"
                    f"c,z,0.060,m,,{q}\n"
                    f"d,z,61.6,mm,,{q}\n"
                    f"e,z,62,mm,1,{q}\n"
                    f"f,z,0.0616,m,,{q}\n"
                    f"g,z,0.0615,m,,{q}\n")
    agrees = audit_published(arm, path).cells.set_index("pose_id")["agrees"].to_dict()
    assert agrees == {"a": True, "b": True, "c": False, "d": True, "e": True, "f": True, "g": False}


def test_audit_bad_published_value(tmp_path, arm):
    path = tmp_path / "pub.csv"
    path.write_text("pose_id,quantity,published,unit,commanded\na,z,zero,m,0 0 0\n")
    with pytest.raises(MeasurementError, match="row 2, column 'published'"):
        audit_published(arm, path)


def test_cli_errors_and_audit(tmp_path, capsys):
    from labkit.cli import main

    html = tmp_path / "t.html"
    assert main(["errors", str(IK_SEED), "--html", str(html)]) == 0
    out = capsys.readouterr().out
    assert "t4_row5" in out and "RMS" in out
    written = html.read_text()
    assert written.startswith('<table class="lk-report-table') and 'style="background-color: #f8c4c4"' in written
    assert "theta1" in out and "max |error|" in out
    assert main(["audit", str(PUBLISHED), "--robot", "arduino_arm_3dof"]) == 1
    out = capsys.readouterr().out
    assert out.startswith("57 of 63 published values agree")
    assert "t3_j3_20deg" in out
    # the published table names no robot: no course arm is assumed, the command says what it needs
    assert main(["audit", str(PUBLISHED)]) == 2
    assert "expected one robot name in the measurements (or a robot argument), got []" in capsys.readouterr().err


def test_ik_table_for_planar_and_6r_targets():
    planar = Robot.load("planar3r_seed004")
    q = np.array([0.3, 0.5, -0.4])
    T = planar.fk(q)
    df = pd.DataFrame({"pose_id": ["a"] * 3, "quantity": ["theta1", "theta2", "theta3"],
                       "value": np.degrees(q), "unit": ["deg"] * 3, "resolution": [0.5] * 3,
                       "target": [np.array([T[0, 3], T[1, 3], 0.4])] * 3})
    table = error_table(planar, df, mode="ik", branch=None).table
    # whichever branch IK picks, it reaches the target
    q_ik = np.radians(table["calculated"].to_numpy())
    np.testing.assert_allclose(planar.fk(q_ik)[:2, 3], T[:2, 3], atol=1e-9)
    with pytest.raises(MeasurementError, match="has no z component"):
        error_table(planar, df.assign(quantity=["z", "x", "y"], unit="m", resolution=0.001), mode="ik")
    puma = Robot.load("puma560")
    q6 = np.array([0.1, -0.4, 0.3, 0.2, 0.5, 0.1])
    T6 = puma.fk(q6)
    df = pd.DataFrame({"pose_id": ["a", "a"], "quantity": ["x", "theta1"], "value": [T6[0, 3], 5.0],
                       "unit": ["m", "deg"], "resolution": [0.001, 0.5], "target": [T6, T6]})
    table = error_table(puma, df, mode="ik", branch=None).table.set_index("quantity")
    assert table.loc["x", "calculated"] == pytest.approx(T6[0, 3])
    assert np.isfinite(table.loc["theta1", "calculated"])


def test_measurements_in_the_robots_place_get_a_clear_error():
    from labkit.exceptions import LabkitError
    from labkit.robot import Robot

    arm = Robot.load("arduino_arm_3dof")
    with pytest.raises(LabkitError, match="expected measurements as a DataFrame or the path of a CSV file, got Robot"):
        error_table(arm, arm)


def test_audit_style_marks_the_disagreeing_rows_and_prints_words(arm):
    audit = audit_published(arm, PUBLISHED, branch="elbow_up")
    t = audit.report_table()
    bad = sorted({r for r, _, _ in t.marks})
    assert bad == list(np.flatnonzero(~audit.cells["agrees"].to_numpy(bool))) and len(bad) == len(audit.flagged) == 6
    assert len(t.marks) == 6 * len(t.header)  # the whole row
    row = dict(zip(t.header, t.rows[bad[0]]))
    assert row["agrees"] == "no" and row["published"] == audit.cells.loc[bad[0], "published"]  # kept as printed
    text = t.to_text() + t.to_html()
    assert not re.search(r"\b(True|False|NaN|nan)\b", text)
    styler = audit.style()
    styler._compute()
    assert sorted({r for (r, _), v in styler.ctx.items() if v}) == bad
    assert styler.data.values.tolist() == [list(r) for r in t.rows]
    # each number in its row's unit: 4 significant digits of the recomputed value (t4_row5 theta1 = 111.8 deg)
    t4 = dict(zip(t.header, t.rows[int(np.flatnonzero((audit.cells.pose_id == "t4_row5") & (audit.cells.quantity == "theta1"))[0])]))
    assert t4["recomputed"] == "111.8" and t4["unit"] == "deg"
