"""No public labkit name shadows a standard-library name that notebooks import or use.

A notebook that does ``from pathlib import Path`` and ``from labkit.motion import *``
(or imports labkit's name after the standard library's) must not lose one of
them: the public names (``__all__``) of every public labkit module are checked
against the builtins, the standard-library module names and the module-level
names of the standard-library modules lab notebooks commonly import.
"""

from __future__ import annotations

import builtins
import importlib
import pkgutil
import sys

import pytest

import labkit

#: standard-library modules whose names notebooks import (``from pathlib import Path``, ``import time``, ...)
COMMON_STDLIB = (
    "pathlib", "os", "os.path", "sys", "math", "cmath", "time", "datetime", "json", "csv", "re", "io",
    "shutil", "subprocess", "tempfile", "glob", "itertools", "functools", "collections", "dataclasses",
    "enum", "typing", "random", "statistics", "fractions", "decimal", "copy", "warnings", "logging",
    "contextlib", "textwrap", "string", "operator", "pprint", "zipfile",
)


def _public_modules():
    names = ["labkit"]
    for info in pkgutil.walk_packages(labkit.__path__, "labkit."):
        if not any(part.startswith("_") for part in info.name.split(".")[1:]):
            names.append(info.name)
    return names


def _stdlib_names():
    """name -> where the standard library defines it."""
    where = {n: "builtins" for n in dir(builtins) if not n.startswith("_")}
    where.update({n: "a standard-library module" for n in sys.stdlib_module_names if not n.startswith("_")})
    for modname in COMMON_STDLIB:
        mod = importlib.import_module(modname)
        public = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
        for n in public:
            where.setdefault(n, f"{modname}.{n}")
    return where


STDLIB = _stdlib_names()


def test_the_scan_sees_the_names_it_guards():
    assert STDLIB["Path"] == "pathlib.Path" and STDLIB["open"] == "builtins" and STDLIB["time"]
    assert {"labkit.motion", "labkit.kinematics", "labkit.reports", "labkit.measure"} <= set(_public_modules())


@pytest.mark.parametrize("module", _public_modules())
def test_public_names_do_not_shadow_the_standard_library(module):
    mod = importlib.import_module(module)
    clashes = {n: STDLIB[n] for n in getattr(mod, "__all__", ()) if n in STDLIB}
    assert not clashes, f"{module} exports names of the standard library: {clashes}"
