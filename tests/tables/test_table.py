"""labkit.tables: the one style of the tables labkit prints (report tables, marked cells, prose values)."""

import html as _html
import re

import numpy as np
import pandas as pd
import pytest

from labkit.exceptions import OptionError, ShapeError
from labkit.tables import HIGHLIGHT, LONG_TABLE_ROWS, css_to_latex, error_report_table, report_table


def test_no_default_index_but_a_meaningful_one_is_kept():
    plain = report_table(pd.DataFrame({"row": [1, 2], "x [m]": [0.1, 0.2]}))
    assert plain.header == ("row", "x [m]")
    named = report_table(pd.DataFrame({"x [m]": [0.1, 0.2]}, index=pd.Index(["a", "b"], name="pose")))
    assert named.header == ("pose", "x [m]") and [r[0] for r in named.rows] == ["a", "b"]
    labelled = report_table(pd.DataFrame({"x [m]": [0.1, 0.2]}, index=["elbow up", "elbow down"]))
    assert labelled.header == ("", "x [m]") and labelled.rows[1][0] == "elbow down"
    assert report_table(pd.DataFrame({"x": [1.0]}, index=["a"]), index=False).header == ("x",)
    subsample = pd.DataFrame({"x": [1.0, 2.0, 3.0, 4.0]}).iloc[::2]  # row numbers 0, 2: still no index
    assert report_table(subsample).header == ("x",)
    html = plain.to_html()
    assert "<th></th>" not in html and ">0<" not in html  # no index column


def test_human_names_units_and_left_out_columns():
    df = pd.DataFrame({"t": [0.0, 0.1], "shoulder_pitch_ddot": [1.0, 2.0], "debug": [1, 2]})
    t = report_table(df, columns={"t": "time [s]", "shoulder_pitch_ddot": "shoulder accel [deg/s^2]",
                                  "debug": None})
    assert t.header == ("time [s]", "shoulder accel [deg/s^2]")
    assert all(len(r) == 2 for r in t.rows)


def test_same_decimals_down_a_column_from_its_largest_magnitude():
    t = report_table(pd.DataFrame({"a [m]": [0.0, 0.012, -0.0016, 1e-17, -2e-18]}), digits=3)
    assert [r[0] for r in t.rows] == ["0.0000", "0.0120", "-0.0016", "0.0000", "0.0000"]  # no -0, no 1e-17
    t = report_table(pd.DataFrame({"q [deg]": [113.865, -45.0, 0.5], "n": [1, 20, 300]}), digits=4)
    assert [r[0] for r in t.rows] == ["113.9", "-45.0", "0.5"]
    assert [r[1] for r in t.rows] == ["1", "20", "300"]  # integers stay integers
    per = report_table(pd.DataFrame({"a": [1.23456], "b": [1.23456]}), digits={"a": 2, "*": 5})
    assert per.rows[0] == ("1.2", "1.2346")
    tiny = report_table(pd.DataFrame({"e [m]": [5.6e-7, 1.2e-6]}), digits=2)
    assert [r[0] for r in tiny.rows] == ["5.6e-7", "1.2e-6"]


def test_booleans_missing_and_vectors_print_as_words_dashes_and_tuples():
    df = pd.DataFrame({"reached": [True, False, None], "err [mm]": [1.5, np.nan, None],
                       "target [m]": [(0.1, 0.1, -0.1), np.array([0.1, -0.1, -0.16]), None]})
    t = report_table(df, digits=2)
    text = t.to_text() + t.to_html() + t.to_latex()
    assert not re.search(r"\b(True|False|NaN|nan|None)\b", text)
    assert [r[0] for r in t.rows] == ["yes", "no", "–"]
    assert [r[1] for r in t.rows] == ["1.5", "–", "–"]
    assert t.rows[0][2] == "(0.10, 0.10, -0.10)" and t.rows[1][2] == "(0.10, -0.10, -0.16)"
    marks = report_table(df[["reached"]], booleans=("✓", "✗"), missing="n/a")
    assert [r[0] for r in marks.rows] == ["✓", "✗", "n/a"]


def test_long_tables_repeat_their_header_and_short_ones_do_not_break():
    short = report_table(pd.DataFrame({"k": range(LONG_TABLE_ROWS)}))
    long = report_table(pd.DataFrame({"k": range(LONG_TABLE_ROWS + 1)}), caption="every sample")
    assert not short.long and "lk-long" not in short.to_html()
    assert long.long and 'class="lk-report-table lk-long"' in long.to_html() and "<thead>" in long.to_html()
    tex = long.to_latex()
    assert tex.startswith(r"\begin{longtable}") and r"\endhead" in tex and r"\caption{every sample}" in tex
    assert short.to_latex().startswith(r"\begin{table}") and r"\toprule" in short.to_latex()


def test_html_escapes_and_latex_escapes():
    t = report_table(pd.DataFrame({"a_b & <c> [%]": ["x_1 <b>"]}), caption="50 % of <rows>")
    assert "&lt;c&gt;" in t.to_html() and "<b>" not in t.to_html() and "&lt;rows&gt;" in t.to_html()
    assert r"a\_b \& <c> [\%]" in t.to_latex() and r"50 \% of" in t.to_latex()


def test_notebook_display_is_the_html_and_the_report_keeps_it():
    from labkit.reports._document import _outputs

    t = report_table(pd.DataFrame({"k": range(LONG_TABLE_ROWS + 5)}))
    assert t._repr_html_() == t.to_html()
    cell = {"outputs": [{"output_type": "execute_result", "data": {"text/html": t.to_html(), "text/plain": repr(t)}}]}
    parts, _ = _outputs(cell, None)
    assert len(parts) == 1 and "lk-report-table" in parts[0]


def test_bad_input_says_what_was_expected():
    df = pd.DataFrame({"a": [1.0]})
    with pytest.raises(ShapeError, match="DataFrame or Series, got list"):
        report_table([1, 2])
    with pytest.raises(OptionError, match="columns names b, which the table does not have"):
        report_table(df, columns={"b": "B"})
    with pytest.raises(OptionError, match="expected digits as an integer >= 1, got 0"):
        report_table(df, digits=0)
    with pytest.raises(OptionError, match="digits names c"):
        report_table(df, digits={"c": 2})
    with pytest.raises(OptionError, match="two words"):
        report_table(df, booleans=("yes",))


def test_units_from_the_frame_or_given_go_into_the_header():
    df = pd.DataFrame({"shoulder_pitch_ddot": [1.0], "x": [2.0], "n [1]": [3]})
    df.attrs["units"] = {"shoulder_pitch_ddot": "deg/s^2", "x": "mm"}
    t = report_table(df, columns={"shoulder_pitch_ddot": "shoulder accel"})
    assert t.header == ("shoulder accel [deg/s^2]", "x [mm]", "n [1]")
    assert report_table(df, units={"x": "m"}).header == ("shoulder_pitch_ddot", "x [m]", "n [1]")


def test_a_two_level_index_prints_as_columns_named_by_its_levels():
    df = pd.DataFrame({"a0": [0.0, 0.18]}, index=pd.MultiIndex.from_tuples([(1, "x [m]"), (1, "y [m]")],
                                                                          names=["segment", "value"]))
    t = report_table(df, columns={"segment": None, "value": "axis", "a0": "a0 [m]"})
    assert t.header == ("axis", "a0 [m]") and t.rows == (("x [m]", "0.000"), ("y [m]", "0.180"))


def test_format_value_prints_prose_numbers_like_the_table_cells():
    from labkit.tables import format_value

    assert format_value([0.0, 94.00000001], digits=3) == "(0.0, 94.0)"  # not [ 0. 94.]
    assert format_value(5.6e-17, unit="m") == "0 m"  # round-off, not 5.6e-17
    assert format_value(np.array([[1.0, -2.0], [3.0, 4.0]]), decimals=1) == "((1.0, -2.0), (3.0, 4.0))"
    assert format_value(True) == "yes" and format_value(float("nan")) == "–"
    assert format_value(94.0, digits=6, like=[94.00012]) == "94.0000"  # the decimals of the values beside it
    assert format_value(94.0, digits=6) == "94.0000" and format_value(0.5, digits=3, like=[1.25]) == "0.50"
    with pytest.raises(OptionError, match="expected zero as a positive finite number, got 0"):
        format_value(1.0, zero=0)
    with pytest.raises(OptionError, match="expected decimals as an integer >= 0, got -1"):
        format_value(1.0, decimals=-1)


def test_the_dh_table_records_its_units_for_the_header():
    from labkit.robot import Robot

    t = report_table(Robot.load("arduino_arm_3dof").dh_table(), columns={"i": "link i"})
    assert t.header[:4] == ("link i", "joint", "type", "a_{i-1} [mm]")
    assert "alpha_{i-1} [deg]" in t.header and "lower [deg]" in t.header


def test_grouped_rows_print_their_label_once_and_stay_together():
    df = pd.DataFrame({"pose": ["a", "a", "b", "b", "b", "a"], "axis": list("xyxyzx"), "v [mm]": [1.0] * 6})
    t = report_table(df, group="pose")
    assert [r[0] for r in t.rows] == ["a", "", "b", "", "", "a"]  # a run of equal labels is a group
    assert t.groups == (0, 2, 5)
    html = t.to_html()
    assert html.count("<tbody>") == 3 and 'class="lk-report-table lk-grouped"' in html
    assert t.to_latex().count(r"\addlinespace") == 2
    plain = report_table(df)
    assert plain.groups == () and plain.to_html().count("<tbody>") == 1 and plain.rows[1][0] == "a"
    with pytest.raises(OptionError, match="group expects columns the table prints, got 'axis'"):
        report_table(df, group="axis", columns={"axis": None})
    two = report_table(df.assign(target=["p", "p", "q", "q", "r", "r"]), group=["pose", "target"])
    assert two.groups == (0, 2, 4, 5)  # a group ends where either label changes
    assert [r[3] for r in two.rows] == ["p", "", "q", "", "r", "r"] and [r[0] for r in two.rows] == ["a", "", "b", "", "b", "a"]


def test_numbers_kept_as_printed_text_align_as_numbers():
    t = report_table(pd.DataFrame({"published": ["0.27", "0.024"], "pose": ["t1", "t2"]}))
    assert t.numeric == (True, False)


def test_error_report_table_is_a_journal_table_of_the_seed_tables():
    from labkit.data import measurement_file
    from labkit.measure import error_table, load_measurements

    readings = load_measurements(measurement_file("seed000_fk_tables1-3.csv"))
    errors = error_table("arduino_arm_3dof", readings[readings.pose_id.str.startswith("t1_")])
    t = error_report_table(errors, unit="mm", scale=1e3)
    assert t.header == ("pose", "quantity", "calculated [mm]", "measured [mm]", "± [mm]", "error [mm]", "within U")
    assert len(t.rows) == 15 and t.groups == (0, 3, 6, 9, 12)  # five poses of x, y, z
    first = dict(zip(t.header, t.rows[0]))
    assert first["pose"] == "q = (5, 0, 0) deg" and first["quantity"] == "x"
    # independent of labkit's FK: the arm's x at joint 1 = 5 deg is (L1 + L2) cos 5 deg, L1 + L2 = 274 mm
    assert float(first["calculated [mm]"]) == pytest.approx(274.0 * np.cos(np.radians(5.0)), abs=0.5)
    for row in t.rows:  # the printed error is the printed measured - calculated, to the printed precision
        cells = dict(zip(t.header, row))
        decimals = len(cells["error [mm]"].partition(".")[2])
        assert all(len(cells[c].partition(".")[2]) == decimals for c in ("calculated [mm]", "measured [mm]"))
        # each printed value is rounded by at most half a unit of its last place
        assert float(cells["error [mm]"]) == pytest.approx(float(cells["measured [mm]"]) - float(cells["calculated [mm]"]),
                                                           abs=1.0001 * 10.0 ** -decimals)
        assert cells["within U"] in ("yes", "no")
    assert [dict(zip(t.header, r))["within U"] for r in t.rows].count("no") == 15 - int(errors.table.inside.sum())
    text = t.to_text() + t.to_html()
    assert not re.search(r"\b(True|False|NaN|nan)\b", text)
    by_id = error_report_table(errors.table, unit="mm", scale=1e3, pose="pose_id", digits={"error": 2, "*": 3})
    assert by_id.rows[0][0] == "t1_j1_5deg" and by_id.rows[0][5] == "7"


def test_error_report_table_says_what_it_expected():
    with pytest.raises(ShapeError, match="lacks calculated"):
        error_report_table(pd.DataFrame({"pose_id": ["a"], "quantity": ["x"], "command": ["q"], "unit": ["m"]}))
    mixed = pd.DataFrame({"pose_id": ["a", "a"], "quantity": ["x", "theta"], "command": ["q"] * 2, "unit": ["m", "deg"],
                          "calculated": [1.0, 2.0], "mean": [1.0, 2.0], "half_range": [0.0, 0.0], "error": [0.0, 0.0],
                          "inside": [True, True]})
    with pytest.raises(OptionError, match="these are in m, deg"):
        error_report_table(mixed, unit="mm", scale=1e3)
    assert error_report_table(mixed).header[2] == "calculated"  # several units, none claimed
    with pytest.raises(OptionError, match="pose expects 'command' or 'pose_id', got 'row'"):
        error_report_table(mixed, pose="row")
    with pytest.raises(OptionError, match="expected scale as a positive finite number, got 0"):
        error_report_table(mixed, scale=0)


def test_reports_prints_through_the_same_tables():
    import labkit.reports
    import labkit.tables

    for name in ("ReportTable", "report_table", "error_report_table", "format_value", "LONG_TABLE_ROWS"):
        assert getattr(labkit.reports, name) is getattr(labkit.tables, name)


def _cells(html):
    """(text, style or None) of every body cell of an HTML table, row by row."""
    return [[(_html.unescape(text), style) for style, text in re.findall(r'<td[^>]*?(?: style="([^"]*)")?>(.*?)</td>', row)]
            for row in re.findall(r"<tr>(.*?)</tr>", html.split("</thead>", 1)[1])]


def test_marked_cells_show_in_html_latex_and_the_styler():
    df = pd.DataFrame({"pose": ["a", "b", "c"], "x [m]": [0.1, float("nan"), 0.25], "ok": [True, False, True]})
    plain = report_table(df)
    t = plain.mark([False, True, False], ["x [m]"]).mark([2], [0, 2], css="color: #00f; font-weight: bold")
    assert t.rows == plain.rows and t.header == plain.header  # marks change no text
    assert t.marks == ((1, 1, HIGHLIGHT), (2, 0, "color: #00f; font-weight: bold"), (2, 2, "color: #00f; font-weight: bold"))
    cells = _cells(t.to_html())
    assert [[c for c, _ in row] for row in cells] == [list(r) for r in t.rows] == [["a", "0.100", "yes"], ["b", "–", "no"],
                                                                                  ["c", "0.250", "yes"]]
    assert {(k, j): s for k, row in enumerate(cells) for j, (_, s) in enumerate(row) if s} == {
        (1, 1): HIGHLIGHT, (2, 0): "color: #00f; font-weight: bold", (2, 2): "color: #00f; font-weight: bold"}
    tex = t.to_latex()
    assert r"b & \cellcolor[HTML]{F8C4C4} -- & no \\" in tex
    assert r"\color[HTML]{0000FF}\bfseries c & 0.250 & \color[HTML]{0000FF}\bfseries yes" in tex
    assert t.to_text() == plain.to_text()
    styler = t.to_styler()
    assert styler.data.values.tolist() == [list(r) for r in t.rows]
    styler._compute()
    assert sorted(k for k, v in styler.ctx.items() if v) == [(1, 1), (2, 0), (2, 2)]
    assert "x [m]" in styler.to_html() and "nan" not in styler.to_html().lower()


def test_marks_and_css_say_what_they_expected():
    t = report_table(pd.DataFrame({"x [m]": [0.1, 0.2]}))
    with pytest.raises(OptionError, match=r"rows expects one flag per row \(2\), got 3"):
        t.mark([True, False, True])
    with pytest.raises(OptionError, match=r"rows expects positions 0..1 .*got \[5\]"):
        t.mark([5])
    with pytest.raises(OptionError, match=r"columns expects printed column names or positions of this table \(x \[m\]\), got 'y'"):
        t.mark([0], ["y"])
    with pytest.raises(OptionError, match="css expects a string"):
        t.mark([0], css=None)
    with pytest.raises(OptionError, match="expected CSS declarations 'property: value', got 'red'"):
        t.mark([0], css="red")
    with pytest.raises(OptionError, match="escape expects None, 'html' or 'latex', got 'rtf'"):
        t.to_styler(escape="rtf")
    assert css_to_latex("background: #abc; border: 1px solid red") == r"\cellcolor[HTML]{AABBCC} "
    assert css_to_latex("background-color: yellow") == r"\cellcolor{yellow} " and css_to_latex("") == ""


def test_styler_escapes_as_the_table_does():
    t = report_table(pd.DataFrame({"a_b & <c> [%]": ["x_1 <b>"]}), caption="50 % of <rows>")
    assert "&lt;c&gt;" in t.to_styler(escape="html").to_html() and "x_1 &lt;b&gt;" in t.to_styler(escape="html").to_html()
    tex = t.to_styler(escape="latex").to_latex()
    assert r"a\_b \& <c> [\%]" in tex and r"x\_1 <b>" in tex and r"50 \% of" in tex


def test_error_report_table_marks_the_flagged_rows_and_names_units_of_mixed_readings():
    long = pd.DataFrame({"pose_id": ["a", "a"], "quantity": ["x", "theta1"], "command": ["q"] * 2, "unit": ["m", "deg"],
                         "calculated": [0.25, 30.0], "mean": [0.26, float("nan")], "half_range": [0.01, 0.5],
                         "error": [0.01, float("nan")], "inside": [True, False]})
    t = error_report_table(long, flagged=[True, False])
    assert [r[1] for r in t.rows] == ["x [m]", "theta1 [deg]"]  # no one unit for the header: each quantity says its own
    assert t.rows[1][3] == "–" and t.rows[1][6] == "no"
    assert sorted((r, c) for r, c, _ in t.marks) == [(0, 3), (0, 5)]  # measured and error of the flagged row
    with pytest.raises(ShapeError, match=r"flagged as one bool per row of the error table, shape \(2,\), got int64 with shape \(3,\)"):
        error_report_table(long, flagged=[1, 0, 1])
