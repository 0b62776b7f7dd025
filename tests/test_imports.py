"""Importing the math layers and asking the CLI for help stay light.

Heavy libraries (scipy, pandas, matplotlib, sympy) are imported where they are
used, so ``import labkit.kinematics`` (and ``labkit --help``) pull none of
them; the CLI builds a subcommand's arguments only when that subcommand is
used, so the top-level help needs no numerical library at all. Checked in a
fresh interpreter (``sys.modules``), never by timing.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "pandas", "matplotlib", "sympy")


def _loaded_after(code):
    """Top-level module names in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    probe = code + "\nimport sys\nprint(' '.join(sorted({m.split('.')[0] for m in sys.modules})))"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, cwd=REPO)
    assert run.returncode == 0, run.stderr
    return set(run.stdout.split()), run


@pytest.mark.parametrize("module", ["labkit", "labkit.robot", "labkit.rotations", "labkit.kinematics"])
def test_math_layers_import_no_heavy_library(module):
    loaded, _ = _loaded_after(f"import labkit, {module}\nfrom labkit.robot import Robot\n"
                              "from labkit.kinematics import fk, ik, ik_numeric, jacobian\n"
                              "fk(Robot.load('puma560'), [0.0] * 6)")
    assert "labkit" in loaded and "numpy" in loaded  # the probe did import and run
    assert not loaded & set(HEAVY), f"import {module} pulled {sorted(loaded & set(HEAVY))}"


def test_cli_help_imports_no_numerical_library():
    loaded, run = _loaded_after(
        "import contextlib, io\nfrom labkit.cli import main\nbuf = io.StringIO()\n"
        "with contextlib.redirect_stdout(buf), contextlib.suppress(SystemExit):\n    main(['--help'])\n"
        "assert 'calibrate' in buf.getvalue() and 'render' in buf.getvalue(), buf.getvalue()"
    )
    assert "labkit" in loaded
    assert not loaded & {"numpy", *HEAVY}, f"labkit --help pulled {sorted(loaded & {'numpy', *HEAVY})}"


def test_lazily_built_subcommands_still_parse_and_show_their_choices(capsys):
    from labkit.cli import build_parser

    args = build_parser().parse_args(["errors", "table.csv", "--combine", "quadrature"])
    assert args.combine == "quadrature" and args.func.__name__ == "_cmd_errors"
    args = build_parser().parse_args(["render", "--timeout", "5"])
    assert args.timeout == 5.0 and args.func.__name__ == "_cmd_render"
    with pytest.raises(SystemExit):
        build_parser().parse_args(["errors", "table.csv", "--combine", "nonsense"])
    assert "invalid choice: 'nonsense'" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        build_parser().parse_args(["calibrate", "--help"])
    assert "joint_offsets" in capsys.readouterr().out
