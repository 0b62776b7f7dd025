"""The package layout keeps its rules (docs/architecture.md), read from the source with ``ast``.

- no import cycles among labkit modules, counting imports inside functions too;
- no ``_private`` module or name imported from outside its own subpackage;
- modules of a subpackage import their siblings, never their own ``__init__``;
- the layers: nothing imports a higher layer at module level, and a lazy import
  of a higher layer only where docs/architecture.md lists it (convenience methods);
- every error labkit raises is a ``LabkitError`` (no bare builtin ``raise``);
- no module over 600 lines.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import labkit

ROOT = Path(labkit.__file__).resolve().parent

#: layer of each top-level unit of labkit (docs/architecture.md); lower layers never import higher ones
LAYERS = {
    "exceptions": 0, "validation": 1, "data": 1,
    "rotations": 2,
    "robot": 3,
    "kinematics": 4,
    "motion": 5,
    "arm": 6,
    "measure": 7,
    "plotting": 8,
    "reports": 9,
    "cli": 10,
    "": 11, "__main__": 11,  # labkit/__init__.py and python -m labkit
}

#: lazy (inside a function) imports of a higher layer that docs/architecture.md allows:
#: convenience methods delegating to the pure functions of the layer above
LAZY_UPWARD = {
    ("labkit.robot._model", "labkit.kinematics"),  # Robot.fk / .jacobian / .ik
    ("labkit.motion._trajectory", "labkit.plotting"),  # Trajectory.plot
}

BUILTIN_ERRORS = {
    "Exception", "ValueError", "TypeError", "RuntimeError", "KeyError", "IndexError", "OSError",
    "IOError", "LookupError", "ArithmeticError", "ZeroDivisionError", "NotImplementedError",
    "AssertionError", "AttributeError",
}


def _module_name(path):
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _unit(module):
    """Top-level unit of a module: 'kinematics' for labkit.kinematics._ik, '' for labkit itself."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _is_package(module):
    return MODULES[module].name == "__init__.py"


def _resolve_from(module, node):
    """Absolute module named by ``from ... import`` in ``module``."""
    if node.level == 0:
        return node.module
    base = module.split(".")
    if not _is_package(module):
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


class _ImportReader(ast.NodeVisitor):
    """Collects labkit imports, marking those inside a function (lazy) apart from module-level ones."""

    def __init__(self, module):
        self.module = module
        self.depth = 0
        self.found = []

    def _function(self, node):
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = _function

    def visit_Import(self, node):
        for alias in node.names:
            if alias.name == "labkit" or alias.name.startswith("labkit."):
                self.found.append((alias.name, None, self.depth > 0, node.lineno))

    def visit_ImportFrom(self, node):
        target = _resolve_from(self.module, node)
        if not target or not (target == "labkit" or target.startswith("labkit.")):
            return
        for alias in node.names:
            sub = f"{target}.{alias.name}"
            if sub in MODULES:  # `from labkit.kinematics import symbolic`: the submodule itself
                self.found.append((sub, None, self.depth > 0, node.lineno))
            else:
                self.found.append((target, alias.name, self.depth > 0, node.lineno))


def _imports(module):
    """(target module, imported name or None, lazy?, line) for every labkit import in ``module``."""
    reader = _ImportReader(module)
    reader.visit(ast.parse(MODULES[module].read_text(encoding="utf-8")))
    return reader.found


GRAPH = {m: _imports(m) for m in MODULES}


def _where(module, line):
    return f"{MODULES[module].relative_to(ROOT.parent)}:{line}"


def test_every_import_names_an_existing_module():
    missing = [f"{_where(m, line)} imports {t}" for m, edges in GRAPH.items() for t, _, _, line in edges
               if t not in MODULES]
    assert not missing, "\n".join(missing)


def test_no_import_cycles_even_through_lazy_imports():
    edges = {m: sorted({t for t, _, _, _ in GRAPH[m] if t in MODULES and t != m}) for m in MODULES}
    # Tarjan's strongly connected components (iterative)
    index, low, on_stack, stack, cycles, counter = {}, {}, set(), [], [], [0]

    def strongconnect(root):
        work = [(root, iter(edges[root]))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(edges[w])))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        cycles.append(sorted(comp))

    for m in MODULES:
        if m not in index:
            strongconnect(m)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_no_private_module_or_name_crosses_a_subpackage_boundary():
    bad = []
    for m, edges in GRAPH.items():
        for target, name, _, line in edges:
            private_module = any(part.startswith("_") for part in target.split(".")[1:])
            private_name = name is not None and name.startswith("_")
            if (private_module or private_name) and _unit(target) != _unit(m):
                bad.append(f"{_where(m, line)} imports {target}{'.' + name if name else ''}")
    assert not bad, "\n".join(bad)


def test_subpackage_modules_import_siblings_not_their_own_init():
    bad = []
    for m, edges in GRAPH.items():
        unit = _unit(m)
        if not unit or _is_package(m) and m.count(".") == 1:
            continue
        package = f"labkit.{unit}"
        for target, name, _, line in edges:
            if target == package:
                bad.append(f"{_where(m, line)} imports {name or target} from its own package {package}")
    assert not bad, "\n".join(bad)


def test_layers_only_import_downwards():
    bad = []
    for m, edges in GRAPH.items():
        for target, name, lazy, line in edges:
            if LAYERS[_unit(target)] <= LAYERS[_unit(m)]:
                continue
            if lazy and (m, f"labkit.{_unit(target)}") in LAZY_UPWARD:
                continue
            bad.append(f"{_where(m, line)} ({_unit(m) or 'labkit'}) imports {target} "
                       f"({_unit(target)}, a higher layer){' lazily' if lazy else ''}")
    assert not bad, "\n".join(bad)


def test_lazy_upward_allowlist_is_still_needed():
    used = {(m, f"labkit.{_unit(t)}") for m, edges in GRAPH.items() for t, _, lazy, _ in edges
            if lazy and LAYERS[_unit(t)] > LAYERS[_unit(m)]}
    assert LAZY_UPWARD <= used, f"stale entries: {LAZY_UPWARD - used}"


def test_every_top_level_unit_has_a_layer():
    assert {_unit(m) for m in MODULES} <= set(LAYERS)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_bare_builtin_raise(module):
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    # a module's __getattr__ must raise AttributeError (PEP 562): that one is the protocol, not an error report
    protocol = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) and f.name == "__getattr__"
                for n in ast.walk(f)}
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None and id(node) not in protocol:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id in BUILTIN_ERRORS:
                bad.append(f"{_where(module, node.lineno)}: raise {exc.id}")
    assert not bad, "every error labkit raises derives from LabkitError:\n" + "\n".join(bad)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_size(module):
    lines = MODULES[module].read_text(encoding="utf-8").count("\n")
    assert lines <= 600, f"{MODULES[module].relative_to(ROOT.parent)} has {lines} lines (limit 600, aim 400)"


def test_the_checks_can_fail():
    """The graph reader sees lazy imports and relative imports (a cycle-free tree is not an empty graph)."""
    lazy = [(m, t) for m, edges in GRAPH.items() for t, _, is_lazy, _ in edges if is_lazy]
    assert ("labkit.robot._model", "labkit.kinematics") in lazy
    assert any(t == "labkit.exceptions" for t, _, _, _ in GRAPH["labkit.kinematics._ik"])
