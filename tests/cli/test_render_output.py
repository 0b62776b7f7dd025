"""Where ``labkit render`` writes, and that its last line says so (issue 36: a newcomer looked for ./reports)."""

from pathlib import Path

import pytest

from labkit.cli import main


@pytest.mark.parametrize("output", [None, "elsewhere/out"])
def test_render_writes_under_the_working_folder_and_its_last_line_names_the_index(tmp_path, monkeypatch, capsys,
                                                                                   output):
    import labkit.reports

    called = {}

    def fake_render(notebooks, out, **options):  # the CLI's part only: which folder it hands over, what it prints
        called.update(notebooks=notebooks, out=out)
        return [], 0.5

    monkeypatch.setattr(labkit.reports, "render", fake_render)
    monkeypatch.chdir(tmp_path)
    argv = ["render", "--no-pdf", "lab_x"] + (["-o", output] if output else [])
    assert main(argv) == 0
    expected = tmp_path / (output or "reports")
    assert called == {"notebooks": ["lab_x"], "out": output or "reports"}
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.endswith(f"; index: {expected / 'index.html'}"), last
    assert Path(last.rsplit("index: ", 1)[1]).is_absolute()
