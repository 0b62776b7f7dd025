"""The package layout keeps its rules (docs/architecture.md), read from the source with ``ast``.

- no import cycles among labkit modules, counting imports inside functions too;
- no ``_private`` module or name imported from outside the (sub)package that holds it;
- modules of a subpackage import their siblings, never their own ``__init__``;
- the layers of docs/architecture.md's table: nothing imports a higher layer or another unit of its
  own layer at module level, a lazy import of a higher layer only where the doc lists it
  (convenience methods), and the table's "imports" column is the real graph;
- one of each helper the doc names (one definition; no second angle wrap);
- every error labkit raises is a ``LabkitError`` (no bare builtin ``raise``);
- no module over 600 lines.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import labkit

ROOT = Path(labkit.__file__).resolve().parent

#: layer of each top-level unit of labkit, read from the table in docs/architecture.md (below):
#: lower layers never import higher ones, and units of one layer never import each other
ARCHITECTURE = ROOT.parent / "docs" / "architecture.md"


def _architecture_table():
    """{unit: (layer, set of units it imports)} from the "## Layers" table of docs/architecture.md."""
    table, inside = {}, False
    for line in ARCHITECTURE.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            inside = line.strip() == "## Layers"
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not inside or len(cells) < 4 or not cells[0].isdigit():
            continue
        imports = {c.strip("` ") for c in cells[3].split(",") if c.strip("` ") not in ("", "nothing")}
        for unit in cells[1].split(","):
            name = unit.strip("` ").removeprefix("labkit.").removeprefix("labkit")
            table[name] = (int(cells[0]), imports)
    return table


TABLE = _architecture_table()
LAYERS = {unit: layer for unit, (layer, _) in TABLE.items()}
LAYERS["__main__"] = LAYERS[""]

#: lazy (inside a function) imports of a higher layer that docs/architecture.md allows:
#: convenience methods delegating to the pure functions of the layer above
LAZY_UPWARD = {
    ("labkit.robot._model", "labkit.kinematics"),  # Robot.fk / .jacobian / .ik
}

#: the helpers docs/architecture.md says exist once: defined in exactly one place in labkit
ONE_OF_EACH = {"wrap_angle", "joint_rates", "within_limits", "check_limits", "checksum", "segment_speed_ok",
               "segment_position_ok", "wire_speed_limits", "wire_calibrations"}

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


def _owner(target, name):
    """The package that owns a private module or name: it may be imported only from inside that package."""
    parts = target.split(".")
    for i, part in enumerate(parts[1:], start=1):
        if part.startswith("_"):
            return ".".join(parts[:i])
    if name is not None and name.startswith("_"):
        return target if _is_package(target) else ".".join(parts[:-1])
    return None


def test_no_private_module_or_name_crosses_a_subpackage_boundary():
    """A private module or name is used only inside the (sub)package that holds it.

    ``labkit.arm._protocol`` serves all of ``labkit.arm``; ``labkit.arm.board._physics``
    only ``labkit.arm.board``: the link and the URL handlers use the board's public names.
    """
    bad = []
    for m, edges in GRAPH.items():
        for target, name, _, line in edges:
            owner = _owner(target, name)
            if owner is not None and not (m == owner or m.startswith(owner + ".")):
                bad.append(f"{_where(m, line)} imports {target}{'.' + name if name else ''} (private to {owner})")
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
            a, b = _unit(m), _unit(target)
            if a == b or LAYERS[b] < LAYERS[a]:
                continue
            if lazy and (m, f"labkit.{b}") in LAZY_UPWARD:
                continue
            side = "a unit of the same layer" if LAYERS[b] == LAYERS[a] else "a higher layer"
            bad.append(f"{_where(m, line)} ({a or 'labkit'}) imports {target} ({b}, {side}){' lazily' if lazy else ''}")
    assert not bad, "\n".join(bad)


def test_lazy_upward_allowlist_is_still_needed():
    used = {(m, f"labkit.{_unit(t)}") for m, edges in GRAPH.items() for t, _, lazy, _ in edges
            if lazy and LAYERS[_unit(t)] > LAYERS[_unit(m)]}
    assert LAZY_UPWARD <= used, f"stale entries: {LAZY_UPWARD - used}"


def test_architecture_table_is_the_real_import_graph():
    """docs/architecture.md lists, per unit, exactly the units it imports (module level or lazily)."""
    real = {}
    for m, edges in GRAPH.items():
        unit = "" if _unit(m) == "__main__" else _unit(m)
        for target, _, _, _ in edges:
            if _unit(target) != _unit(m):
                real.setdefault(unit, set()).add(_unit(target) or "labkit")
    wrong = []
    for unit, (_, documented) in sorted(TABLE.items()):
        documented = {d.removeprefix("labkit.") for d in documented}
        actual = real.get(unit, set()) - {unit}
        if documented != actual:
            wrong.append(f"{unit or 'labkit'}: documented {sorted(documented)}, imports {sorted(actual)}")
    assert not wrong, "docs/architecture.md, ## Layers:\n" + "\n".join(wrong)


def test_one_of_each_helper_the_architecture_names():
    text = ARCHITECTURE.read_text(encoding="utf-8")
    defined = {}
    for m in MODULES:
        for node in ast.walk(ast.parse(MODULES[m].read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.name in ONE_OF_EACH:
                defined.setdefault(node.name, []).append(_where(m, node.lineno))
    assert all(f"`{name}" in text or f".{name}`" in text for name in ONE_OF_EACH), "name each helper in the doc"
    twice = {name: where for name, where in defined.items() if len(where) != 1}
    assert not twice and set(defined) == ONE_OF_EACH, twice or ONE_OF_EACH - set(defined)


def test_no_second_angle_wrap():
    """An angle wrap is ``labkit.rotations.wrap_angle``: no other module rounds to whole turns of 2 pi."""
    bad = []
    for m in MODULES:
        if m == "labkit.rotations._elementary":
            continue
        for node in ast.walk(ast.parse(MODULES[m].read_text(encoding="utf-8"))):
            text = ast.unparse(node) if isinstance(node, (ast.Call, ast.BinOp)) else ""
            turn = any(t in text for t in ("2 * np.pi", "2 * math.pi", "2.0 * np.pi", "2.0 * math.pi", "tau", "TWO_PI"))
            if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                    "ceil", "floor", "round", "remainder", "fmod", "mod") and turn:
                bad.append(f"{_where(m, node.lineno)}: {text}")
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mod) and "pi" in ast.unparse(node.right):
                bad.append(f"{_where(m, node.lineno)}: {text}")
    assert not bad, "use labkit.rotations.wrap_angle:\n" + "\n".join(bad)


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
