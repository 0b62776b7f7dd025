"""One vocabulary across the library, read from the public signatures.

Every function, class (its constructor) and public method that a public labkit module
exports (its ``__all__``) is checked against the rules of ``/docs/architecture.md``
("One vocabulary"):

* a parameter named ``robot`` is the first one (after ``self``) and positional;
* no parameter is called ``method`` or ``axes`` (a time law is ``law``, plotting takes ``ax``);
* a parameter called ``kind`` is a target kind: every value its docstring lists is one that
  :func:`labkit.kinematics.task_rows` accepts;
* a parameter whose default names a time law (a :class:`labkit.motion.LawName`) is called ``law``;
* a speed or acceleration limit that has a default defaults to ``None`` (absent), never ``inf``;
* no default belongs to one course's arm or seed: no string default is a bundled robot's name
  or an IK branch name, and no default is a module constant named after a seed (``SEED...``);

and every exception or warning class that any public module exports is defined in
:mod:`labkit.exceptions`.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import dataclasses
from functools import lru_cache

import numpy as np
import pytest

import labkit

#: callables whose signature another library fixes, with why: each entry must still break the rule
#: (``test_exemptions_are_still_needed``), so that an entry no longer needed is deleted.
FIXED_ELSEWHERE = {
    ("labkit.arm.urlhandler.bus_port.BusSerial", "robot"):
        "a pyserial URL handler: serial_for_url(url, **options) constructs it as cls(None, *args, **options), "
        "so the port comes first and the robot arrives as a keyword option",
}


SPEED_LIMIT = re.compile(r"^(v|a|qd|qdd)_max$|^max_(velocity|acceleration|speed)$|(speed|rate|velocity)_limit$")
TIME_LAW_PARAMETER = "law"


def _public_modules():
    """Public modules: no ``_private`` part, and reachable from their parent (not shadowed by a name)."""
    names = []
    for info in pkgutil.walk_packages(labkit.__path__, "labkit."):
        parts = info.name.split(".")[1:]
        if info.name == "labkit.__main__" or any(p.startswith("_") for p in parts):
            continue
        mod = importlib.import_module(info.name)
        parent, _, leaf = info.name.rpartition(".")
        if getattr(importlib.import_module(parent), leaf, None) is not mod:
            continue  # e.g. a package shadowed by the function of the same name
        names.append(info.name)
    return names


@lru_cache(maxsize=None)
def _exports():
    """``{qualified name: object}`` of everything public modules export, deduplicated by object."""
    out, seen = {}, set()
    for modname in _public_modules():
        mod = importlib.import_module(modname)
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if id(obj) in seen:
                continue
            seen.add(id(obj))
            out[f"{modname}.{name}"] = obj
    return out


def _callables(exports):
    """``(qualified name, callable, parameters)`` of every exported function, class and public method.

    A dataclass's generated ``__init__`` is marked (``record=True``): its parameters are fields,
    read as attributes more than passed as arguments.
    """
    found = []
    for qual, obj in exports.items():
        if inspect.isfunction(obj):
            found.append((qual, obj, False))
        elif inspect.isclass(obj) and obj.__module__.startswith("labkit"):
            found.append((qual, obj, dataclasses.is_dataclass(obj)))
            for name, member in vars(obj).items():
                if not name.startswith("_") and (inspect.isfunction(member)
                                                 or isinstance(member, (classmethod, staticmethod))):
                    found.append((f"{qual}.{name}", getattr(obj, name), False))
    out = []
    for qual, fn, record in found:
        try:
            sig = inspect.signature(fn)
        except (TypeError, ValueError):
            continue
        params = [p for p in sig.parameters.values() if p.name not in ("self", "cls")]
        out.append((qual, fn, params, record))
    return out


@lru_cache(maxsize=None)
def _course_names():
    """Bundled robot names and every IK branch name of the bundled robots."""
    from labkit.kinematics import fk, ik_all, target_from_pose
    from labkit.robot import Robot, bundled_robots

    names = set(bundled_robots())
    branches = set()
    for name in bundled_robots():
        robot = Robot.load(name)
        q = np.array([np.mean(lk.limits) for lk in robot.links])
        branches |= set(ik_all(robot, target_from_pose(robot, fk(robot, q))).branches)
    return names, branches


@lru_cache(maxsize=None)
def _seed_constants():
    """Ids of module constants named after a seed (``SEED000_SWEEPS``...)."""
    ids = set()
    for modname in _public_modules():
        mod = importlib.import_module(modname)
        for name, value in vars(mod).items():
            if name.upper().startswith("SEED") and not callable(value):
                ids.add(id(value))
    return ids


def _violations(exports):
    """``{(qualified name, parameter): what is wrong}`` over every exported callable."""
    from labkit.kinematics import task_rows
    from labkit.motion import LawName

    law_names = {m.value for m in LawName}
    robots, branches = _course_names()
    seeds = _seed_constants()
    bad = {}
    for qual, fn, params, record in _callables(exports):
        for i, p in enumerate(params):
            key = (qual, p.name)
            default = p.default
            if p.name == "robot" and not record and (i != 0 or p.kind not in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)):
                bad[key] = f"robot is parameter {i + 1} ({p.kind.description}); expected the first, positional"
            if p.name in ("method", "axes"):
                bad[key] = f"a parameter named {p.name!r} (a time law is 'law', plotting takes 'ax')"
            if p.name == "kind":
                doc = inspect.getdoc(fn) or ""
                m = re.search(r"^kind : \{([^}]*)\}", doc, re.M)
                values = re.findall(r'"([^"]+)"', m.group(1)) if m else []
                not_targets = []
                for v in values:
                    try:
                        task_rows(v)
                    except Exception:
                        not_targets.append(v)
                if not values or not_targets:
                    bad[key] = (f"'kind' means a target kind only; its documented values "
                                f"{values or '(none listed)'} include non-target kinds {not_targets}")
            if default is p.empty:
                continue
            if isinstance(default, str) and default in law_names | {m for m in LawName} and p.name != TIME_LAW_PARAMETER:
                bad[key] = f"defaults to the time law {default!r}; a time law is chosen by 'law='"
            if SPEED_LIMIT.search(p.name) and default is not None:
                bad[key] = f"a speed limit that defaults to {default!r}; an absent limit is None"
            if isinstance(default, str) and (default in robots or default in branches):
                bad[key] = f"defaults to {default!r}, a bundled robot or IK branch: a default must suit any robot"
            if id(default) in seeds and not isinstance(default, (bool, int, float, str, type(None))):
                bad[key] = "defaults to a seed's constant: a default must suit any robot"
    return bad


def test_public_signatures_follow_the_vocabulary():
    bad = {k: v for k, v in _violations(_exports()).items() if k not in FIXED_ELSEWHERE}
    assert not bad, "\n".join(f"{q}({p}): {why}" for (q, p), why in sorted(bad.items()))


def test_exemptions_are_still_needed():
    """An entry of FIXED_ELSEWHERE whose rule now holds is stale: delete it."""
    found = _violations(_exports())
    stale = [k for k in FIXED_ELSEWHERE if k not in found]
    assert not stale, f"these now follow the vocabulary; delete them from FIXED_ELSEWHERE: {stale}"


def _foreign_exceptions(exports):
    """Exported exception or warning classes defined outside labkit.exceptions."""
    return sorted(q for q, obj in exports.items()
                  if inspect.isclass(obj) and issubclass(obj, BaseException)
                  and obj.__module__.startswith("labkit") and obj.__module__ != "labkit.exceptions")


def test_the_rules_catch_what_they_forbid():
    """The checks themselves: a function written the old way breaks every rule."""
    from labkit.exceptions import LabkitError
    from labkit.measure import SEED000_SWEEPS

    def old(traj, robot, *, method="via_cubic", axes=None, kind="scatter", v_max=np.inf, shape="cubic",
            branch="elbow_up", default_robot="arduino_arm_3dof", sweeps=SEED000_SWEEPS):
        """Old vocabulary.

        Parameters
        ----------
        kind : {"scatter", "filled"}
        """

    class OldError(LabkitError):
        pass

    OldError.__module__ = old.__module__ = "labkit.fake"
    fake = {"labkit.fake.old": old, "labkit.fake.OldError": OldError}
    found = {p for (q, p) in _violations(fake)}
    assert found == {"robot", "method", "axes", "kind", "v_max", "shape", "branch", "default_robot", "sweeps"}
    assert _foreign_exceptions(fake) == ["labkit.fake.OldError"]


def test_every_exported_exception_is_defined_in_labkit_exceptions():
    assert not _foreign_exceptions(_exports())


def test_labkit_exceptions_exports_every_class_it_defines():
    import labkit.exceptions as ex

    defined = {n for n, v in vars(ex).items() if inspect.isclass(v) and v.__module__ == "labkit.exceptions"}
    assert defined == {n for n in ex.__all__ if inspect.isclass(getattr(ex, n))}


@pytest.mark.parametrize("module", ["labkit.vision", "labkit.measure", "labkit.arm"])
def test_subpackages_re_export_the_exceptions_they_raise(module):
    """Where a subpackage re-exports an exception, it is the one class of labkit.exceptions."""
    import labkit.exceptions as ex

    mod = importlib.import_module(module)
    shared = [n for n in getattr(mod, "__all__", ()) if n in ex.__all__]
    assert shared, f"{module} re-exports none of its exceptions"
    assert all(getattr(mod, n) is getattr(ex, n) for n in shared)
