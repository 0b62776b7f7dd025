"""Every public function, class and method of labkit has a numpydoc docstring.

Every module of the package is checked, the private modules inside the
subpackages (``labkit.kinematics._forward`` ...) included; only ``__main__``
is skipped. The API of a public module is ``__all__`` if the module defines it,
else the public names whose ``__module__`` is the module. The API of a private
module is every public name (not starting with ``_``) defined in it, plus its
``__all__``. A name a module re-exports from another checked module is checked
where it is defined (one report per gap). For every public function and class
of that API, and every public method defined on such a class itself (properties,
dataclass-generated methods and ``_private`` helpers are exempt):

- a docstring exists;
- a function or method with parameters (other than ``self``/``cls``) has a
  ``Parameters`` section (the word on its own line, underlined with dashes) with
  an entry for every parameter (``*args``/``**kwargs`` may instead be covered by
  an ``Other Parameters`` section);
- a function or method whose body has ``return <expr>`` has a ``Returns``
  section (a generator: ``Yields`` or ``Returns``).

One test per module; a failure lists ``module.name: what is missing``.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import re
import textwrap
from pathlib import Path

import pytest

import labkit

ROOT = Path(labkit.__file__).resolve().parent


def _module_name(path):
    """``labkit/kinematics/_forward.py`` -> ``labkit.kinematics._forward`` (``__init__`` -> the package)."""
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_private(name):
    """``labkit.kinematics._forward`` is private (a ``_`` part), ``labkit.kinematics`` is public."""
    return any(part.startswith("_") for part in name.split(".")[1:])


# read from the source tree, not found by importing: a module that fails to import fails its test
MODULES = sorted(_module_name(p) for p in ROOT.rglob("*.py") if p.stem != "__main__")

_HEADER = re.compile(r"^(\S[^\n]*)\n-{3,}[ \t]*$", re.MULTILINE)


def _sections(doc):
    """Map numpydoc section title -> body text (``{}`` when there are none)."""
    doc = inspect.cleandoc(doc)
    heads = list(_HEADER.finditer(doc))
    out = {}
    for k, m in enumerate(heads):
        end = heads[k + 1].start() if k + 1 < len(heads) else len(doc)
        out[m.group(1).strip()] = doc[m.end() : end]
    return out


def _entry_names(body):
    """Names documented in a Parameters-like section body (``a, b : float`` -> a, b)."""
    names = set()
    for line in textwrap.dedent(body.strip("\n")).splitlines():
        if not line or line[0].isspace():
            continue  # description lines are indented below their entry
        head = line.split(" :", 1)[0] if " :" in line else line.split(":", 1)[0]
        for name in head.split(","):
            name = name.strip()
            if re.fullmatch(r"\*{0,2}[A-Za-z_]\w*", name):
                names.add(name.lstrip("*"))
    return names


class _ReturnFinder(ast.NodeVisitor):
    """Does a function body (not nested functions/classes) return a value or yield?"""

    def __init__(self):
        self.returns = False
        self.yields = False

    def visit_Return(self, node):
        if node.value is not None and not (isinstance(node.value, ast.Constant) and node.value.value is None):
            self.returns = True

    def visit_Yield(self, node):
        self.yields = True

    visit_YieldFrom = visit_Yield

    def _skip(self, node):
        pass

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = visit_ClassDef = _skip


def _returns_and_yields(func):
    """(returns a value, is a generator) from the function's source."""
    try:
        source = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return False, False
    try:
        node = ast.parse(source).body[0]
    except SyntaxError:
        node = None
    if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):  # the file changed after the import
        raise AssertionError(f"{func.__qualname__}: the source file no longer matches the imported code")
    finder = _ReturnFinder()
    for stmt in node.body:
        finder.visit(stmt)
    return finder.returns, finder.yields


def _function_problems(qualname, func):
    """What the docstring of ``func`` lacks (list of messages)."""
    func = inspect.unwrap(func)
    doc = func.__doc__
    if not doc or not doc.strip():
        return [f"{qualname}: no docstring"]
    problems = []
    sections = _sections(doc)
    params = [
        p for name, p in inspect.signature(func).parameters.items() if name not in ("self", "cls")
    ]
    if params:
        if "Parameters" not in sections:
            problems.append(f"{qualname}: no Parameters section (for {', '.join(p.name for p in params)})")
        else:
            documented = _entry_names(sections["Parameters"])
            other = "Other Parameters" in sections
            if other:
                documented |= _entry_names(sections["Other Parameters"])
            missing = [
                p.name
                for p in params
                if p.name not in documented
                and not (other and p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD))
            ]
            if missing:
                problems.append(f"{qualname}: Parameters section lacks {', '.join(missing)}")
    returns, yields = _returns_and_yields(func)
    if yields and not ({"Yields", "Returns"} & sections.keys()):
        problems.append(f"{qualname}: no Yields section")
    elif returns and not yields and "Returns" not in sections:
        problems.append(f"{qualname}: no Returns section")
    return problems


def _class_doc(cls):
    """The class's own docstring, or None (ignoring the one ``dataclass`` makes up)."""
    doc = vars(cls).get("__doc__")
    if not doc or not doc.strip():
        return None
    if dataclasses.is_dataclass(cls):
        try:
            generated = cls.__name__ + str(inspect.signature(cls)).replace(" -> None", "")
        except (TypeError, ValueError):
            generated = None
        if doc == generated:
            return None
    return doc


def _dataclass_generated(cls, name):
    """Methods that ``dataclasses`` adds (all dunders today, but be explicit)."""
    return dataclasses.is_dataclass(cls) and name in {
        "__init__", "__repr__", "__eq__", "__hash__", "__setattr__", "__delattr__",
        "__lt__", "__le__", "__gt__", "__ge__", "__match_args__", "__getstate__", "__setstate__",
    }


def _defined_here(module):
    """Public names whose object was defined in ``module`` itself."""
    return [
        n
        for n, obj in vars(module).items()
        if not n.startswith("_") and getattr(obj, "__module__", None) == module.__name__
    ]


def _public_api(module):
    """(name, object) pairs of the module's public functions and classes."""
    if _is_private(module.__name__):
        names = list(dict.fromkeys([*getattr(module, "__all__", ()), *_defined_here(module)]))
    elif hasattr(module, "__all__"):
        names = list(module.__all__)
    else:
        names = _defined_here(module)
    api = []
    for name in names:
        if not hasattr(module, name):
            continue  # reported by module_problems
        obj = getattr(module, name)
        home = getattr(inspect.unwrap(obj) if callable(obj) else obj, "__module__", None)
        if home != module.__name__ and home in MODULES:
            continue  # a re-export: checked in the module that defines it
        if inspect.isclass(obj) or inspect.isfunction(inspect.unwrap(obj) if callable(obj) else obj):
            api.append((name, obj))
    return api


def module_problems(module):
    """Every docstring problem of the public API of ``module``."""
    problems = []
    for name in getattr(module, "__all__", ()):
        if not hasattr(module, name):
            problems.append(f"{module.__name__}.{name}: listed in __all__ but not defined")
    for name, obj in _public_api(module):
        qualname = f"{module.__name__}.{name}"
        if not inspect.isclass(obj):
            problems += _function_problems(qualname, obj)
            continue
        if _class_doc(obj) is None:
            problems.append(f"{qualname}: no class docstring")
        for attr, member in vars(obj).items():
            if attr.startswith("_") or _dataclass_generated(obj, attr):
                continue
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            if inspect.isfunction(member):
                problems += _function_problems(f"{qualname}.{attr}", member)
    return problems


def test_modules_found():
    """The discovery itself works (otherwise every other test passes vacuously)."""
    assert {"labkit", "labkit.kinematics", "labkit.kinematics.symbolic", "labkit.cli", "labkit.arm"} <= set(MODULES)
    private = {"labkit.kinematics._forward", "labkit.kinematics._ik", "labkit.arm.board._board", "labkit.cli._arm"}
    assert private <= set(MODULES)
    assert "labkit.__main__" not in MODULES
    assert not any(m.endswith(".__main__") for m in MODULES)
    assert _is_private("labkit.measure._log") and not _is_private("labkit.robot.types")


def test_private_modules_check_their_public_names():
    """A private module's public-named function is checked even when ``__all__`` leaves it out,
    and a re-exported name is checked once, where it is defined."""
    render = importlib.import_module("labkit.reports._render")
    names = {name for name, _ in _public_api(render)}
    assert {"chromium_command", "find_chromium", "render"} <= names
    assert not {name for name, _ in _public_api(render) if name.startswith("_")}
    reports = importlib.import_module("labkit.reports")
    assert "render" in reports.__all__ and "render" not in {name for name, _ in _public_api(reports)}


def test_checker_catches_gaps():
    """The checker reports each kind of gap it is meant to catch."""

    def undocumented(x):
        return x

    def no_returns(x, *, scale=1.0):
        """Scale.

        Parameters
        ----------
        x : float
            Value.
        """
        return x * scale

    def complete(x, y, *args, **kwargs):
        """Sum.

        Parameters
        ----------
        x, y : float
            Values [m].
        **kwargs
            Ignored.

        Other Parameters
        ----------------
        *args
            Ignored.

        Returns
        -------
        float
            ``x + y`` [m].
        """
        return x + y

    def generator(n):
        """Count.

        Parameters
        ----------
        n : int
            How many.
        """
        yield from range(n)

    def returns_nothing(x):
        """Only a nested function returns a value.

        Parameters
        ----------
        x : int
            Unused.
        """

        def inner():
            return x

        return None

    @dataclasses.dataclass
    class Undocumented:
        x: float

    assert _function_problems("f", undocumented) == ["f: no docstring"]
    assert _function_problems("f", generator) == ["f: no Yields section"]
    assert _function_problems("f", returns_nothing) == []
    assert _class_doc(Undocumented) is None
    assert _function_problems("f", no_returns) == [
        "f: Parameters section lacks scale",
        "f: no Returns section",
    ]
    assert _function_problems("f", complete) == []


@pytest.mark.parametrize("name", MODULES)
def test_public_docstrings_are_complete(name):
    module = importlib.import_module(name)
    problems = module_problems(module)
    assert not problems, f"{len(problems)} docstring gap(s) in {name}:\n" + "\n".join(problems)


#: where the docstring examples of the former flat modules live now, and how many there must be at
#: least (the hand-written ``doctest.testmod`` tests asserted ``attempted > 0``, for ``labkit.ik`` > 5;
#: pytest ``--doctest-modules`` now runs the examples, this keeps them from silently disappearing)
EXAMPLES_KEPT = {
    "labkit.ik": (("labkit.kinematics._ik",), 6),
    "labkit.kinematics": (("labkit.kinematics._forward",), 1),
    "labkit.rotations": (("labkit.rotations._elementary", "labkit.rotations._matrix"), 1),
    "labkit._euler": (("labkit.rotations._euler",), 1),
    "labkit.dh": (("labkit.robot._model", "labkit.robot.types", "labkit.robot._files"), 1),
    "labkit._paths": (("labkit.motion._paths",), 1),
    "labkit.calibration": (("labkit.measure._calibration",), 1),
    "labkit.errortables": (("labkit.measure._errortables", "labkit.measure._calculated"), 1),
    "labkit.audit": (("labkit.measure._audit",), 1),
    "labkit.measurement": (("labkit.measure._schema", "labkit.measure._log", "labkit.measure._csv"), 1),
}


@pytest.mark.parametrize("old", sorted(EXAMPLES_KEPT))
def test_docstring_examples_kept(old):
    import doctest

    modules, minimum = EXAMPLES_KEPT[old]
    finder = doctest.DocTestFinder()
    found = sum(len(t.examples) for name in modules for t in finder.find(importlib.import_module(name)))
    assert found >= minimum, f"the examples of the former {old} ({', '.join(modules)}): {found} < {minimum}"
