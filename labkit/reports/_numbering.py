"""Labels, captions and cross-references in lab notebooks (the Quarto convention).

A code cell opens with cell options, one per line::

    #| label: fig-fk-error
    #| fig-cap: "Measured minus calculated position, tables 1-3 (the seed's Figure 5)"

``fig-cap`` numbers the cell's figures ("Figure 2.1"), ``tbl-cap`` its tables ("Table 2.1",
the caption above the table); a list gives one caption per figure or table of the cell. A
display equation in markdown is labelled after its closing ``$$``: ``$$ ... $$ <a id="eq-fk"></a>``
(an anchor a live notebook hides) or Quarto's ``$$ ... $$ {#eq-fk}`` (which it shows as text); a heading
with ``{#sec-name}``. Markdown refers to them as ``[Figure](#fig-fk-error)``,
``[Table](#tbl-...)``, ``[Equation](#eq-...)``, ``[Chapter](#sec-...)`` (a link that reads well in a
live notebook) or Quarto's ``@fig-fk-error``; :func:`number_notebooks` gives every label its number
and :func:`resolve_references` writes the references as "Figure 2.1" (a link).

Example
-------
>>> from labkit.reports._numbering import cell_options
>>> cell_options('#| label: fig-a\\n#| fig-cap: "The arm"\\nplot()')
({'label': 'fig-a', 'fig-cap': 'The arm'}, 'plot()')
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from labkit.exceptions import LabkitError

__all__ = ["Label", "cell_options", "number_notebooks", "resolve_references", "KIND_NAMES"]

#: printed name of each label kind
KIND_NAMES = {"fig": "Figure", "tbl": "Table", "eq": "Equation", "sec": "Chapter"}
_OPTION = re.compile(r"^#\|\s?(.*)$")
#: a labelled display equation: ``$$ ... $$ {#eq-x}`` (Quarto's), or ``$$ ... $$ <a id="eq-x"></a>``, an
#: anchor a live notebook hides where it shows Quarto's attribute as text
_EQUATION = re.compile(r"\$\$(?P<tex>.+?)\$\$[ \t]*(?:\{#(?P<label>eq-[\w-]+)\}|<a id=\"(?P<anchor>eq-[\w-]+)\"></a>)",
                       re.DOTALL)


def _equation_label(m):
    """The label of an :data:`_EQUATION` match, in either of its forms."""
    return m.group("label") or m.group("anchor")
_HEADING_LABEL = re.compile(r"^(?P<head>#{1,6} .*?)[ \t]*\{#(?P<label>sec-[\w-]+)\}[ \t]*$", re.MULTILINE)
#: a reference: ``@fig-x`` (Quarto's), or ``[Figure](#fig-x)``, which reads as a link in a live notebook
REFERENCE = re.compile(r"\[[^\]\n]*\]\(#(?P<linked>(?:fig|tbl|eq|sec)-[\w-]*\w)\)"
                       r"|(?<![\w@/.#])@(?P<label>(?:fig|tbl|eq|sec)-[\w-]*\w)")


@dataclass(frozen=True)
class Label:
    """A numbered item.

    Attributes
    ----------
    label : str
        ``fig-...``, ``tbl-...``, ``eq-...`` or ``sec-...``.
    kind : str
        ``"fig"``, ``"tbl"``, ``"eq"`` or ``"sec"``.
    number : str
        ``"2.1"`` (chapter 2, first of its kind) or ``"1"`` in a single-notebook report.
    caption : str
        Caption (markdown), "" for equations and sections.
    notebook : int
        Index of the notebook (chapter - 1).
    cell : int
        Index of the cell in that notebook.
    anchor : str
        HTML id of the item: the label, or ``<label>-<chapter>`` in a many-chapter report
        (notebooks of one lab may each have a ``tbl-dh``).
    """

    label: str
    kind: str
    number: str
    caption: str = ""
    notebook: int = 0
    cell: int = 0
    anchor: str = ""

    @property
    def text(self) -> str:
        """How a reference prints: ``"Figure 2.1"``, ``"Equation (2.1)"``."""
        if self.kind == "eq":
            return f"Equation ({self.number})"
        return f"{KIND_NAMES[self.kind]} {self.number}"


def _simple_yaml(lines):
    out = {}
    for line in lines:
        key, sep, value = line.partition(":")
        if not sep:
            raise LabkitError(f"a cell option is 'key: value', got {line!r}")
        out[key.strip()] = value.strip().strip('"').strip("'")
    return out


def cell_options(source: str):
    """The ``#|`` options at the top of a code cell and the code without them.

    Parameters
    ----------
    source : str
        Code cell source.

    Returns
    -------
    (dict, str)
        Options (YAML values: a caption string or a list of them) and the remaining source.

    Raises
    ------
    LabkitError
        An option line that is not ``key: value``.
    """
    lines = source.splitlines()
    opts = []
    for line in lines:
        m = _OPTION.match(line)
        if not m:
            break
        opts.append(m.group(1))
    if not opts:
        return {}, source
    rest = "\n".join(lines[len(opts):])
    try:
        import yaml

        parsed = yaml.safe_load("\n".join(opts))
    except ImportError:  # pragma: no cover - PyYAML comes with jupyter
        parsed = _simple_yaml(opts)
    except yaml.YAMLError:
        parsed = _simple_yaml(opts)
    if not isinstance(parsed, dict):
        raise LabkitError(f"cell options must be 'key: value' lines, got {opts!r}")
    return parsed, rest


def _as_list(value):
    if value is None:
        return []
    return [str(v) for v in value] if isinstance(value, (list, tuple)) else [str(value)]


def number_notebooks(notebooks, *, chapters=True, first_chapter=1) -> dict:
    """Number every labelled or captioned figure, table, equation and chapter.

    Parameters
    ----------
    notebooks : sequence of nbformat.NotebookNode
        The notebooks of a report, in chapter order.
    chapters : bool
        Number as ``chapter.n`` ("Figure 2.1"); False for a one-notebook report ("Figure 1").
    first_chapter : int
        Chapter number of the first notebook (a per-notebook report of a lab's third
        notebook numbers its figures "Figure 3.n", as the lab report does).

    Returns
    -------
    dict
        ``{"labels": {label: Label}, "local": [{label: Label}, ...], "cells": {(notebook, cell):
        {"fig": [Label...], "tbl": [Label...]}}}``: ``labels`` holds the labels defined in one
        notebook only, ``local`` each notebook's own (a reference resolves there first, so
        every notebook may have its ``tbl-dh``), ``cells`` the captions of each cell in output
        order (an unlabelled caption gets the label ``fig-<notebook>-<cell>-<k>``).

    Raises
    ------
    LabkitError
        A label defined twice in one notebook (naming both cells).
    """
    local, cells = [{} for _ in notebooks], {}
    owners = {}

    def add(item, where):
        own = local[item.notebook]
        if item.label in own:
            raise LabkitError(f"label {item.label} is defined twice in notebook {item.notebook + 1}: cell "
                              f"{own[item.label].cell + 1} and {where}")
        own[item.label] = item
        owners.setdefault(item.label, []).append(item)

    for k, nb in enumerate(notebooks):
        chapter = k + first_chapter
        prefix = f"{chapter}." if chapters else ""
        count = {"fig": 0, "tbl": 0, "eq": 0}

        def anchor(label, k=k):
            return f"{label}-{k + 1}" if chapters else label

        for i, cell in enumerate(nb.cells):
            where = f"notebook {k + 1} cell {i + 1}"
            if cell.cell_type == "markdown":
                for m in _HEADING_LABEL.finditer(cell.source):
                    add(Label(m.group("label"), "sec", str(chapter), "", k, i, anchor(m.group("label"))), where)
                for m in _EQUATION.finditer(cell.source):
                    count["eq"] += 1
                    add(Label(_equation_label(m), "eq", f"{prefix}{count['eq']}", "", k, i, anchor(_equation_label(m))),
                        where)
                continue
            if cell.cell_type != "code":
                continue
            opts, _ = cell_options(cell.source)
            if not opts:
                continue
            label = str(opts.get("label", "") or "")
            entry = {}
            for kind in ("fig", "tbl"):
                caps = _as_list(opts.get(f"{kind}-cap"))
                if not caps and label.startswith(kind + "-"):
                    caps = [""]
                items = []
                for j, cap in enumerate(caps):
                    count[kind] += 1
                    name = label if (j == 0 and label.startswith(kind + "-")) else f"{kind}-{k + 1}-{i + 1}-{j + 1}"
                    item = Label(name, kind, f"{prefix}{count[kind]}", cap, k, i, anchor(name))
                    add(item, where)
                    items.append(item)
                if items:
                    entry[kind] = items
            if entry:
                cells[(k, i)] = entry
    unique = {label: items[0] for label, items in owners.items() if len(items) == 1}
    return {"labels": unique, "local": local, "cells": cells}


def resolve_references(markdown: str, labels: dict, *, link=True, unresolved=None) -> str:
    """Write ``[Figure](#fig-x)`` and ``@fig-x`` references as ``[Figure 2.1](#fig-x)``; number labelled equations.

    Parameters
    ----------
    markdown : str
        Markdown cell source.
    labels : dict of str to Label
        From :func:`number_notebooks`.
    link : bool
        Make each reference a link to its target.
    unresolved : list, optional
        Labels referred to but not defined are appended here; they print as ``?@label``.

    Returns
    -------
    str
        The markdown with the references written out, ``\\tag{2.1}`` in labelled equations
        and the ``{#...}`` attributes removed.
    """

    def ref(m):
        label = m.group("label") or m.group("linked")
        item = labels.get(label)
        if item is None:
            if unresolved is not None:
                unresolved.append(label)
            return f"**?@{label}**"
        return f"[{item.text}](#{item.anchor or item.label})" if link else item.text

    def equation(m):
        item = labels.get(_equation_label(m))
        number = item.number if item else "?"
        anchor = f'<span id="{item.anchor if item else _equation_label(m)}"></span>\n\n' if link else ""
        return f"{anchor}$${m.group('tex').rstrip()} \\tag{{{number}}}$$"

    text = _EQUATION.sub(equation, markdown)
    text = _HEADING_LABEL.sub(lambda m: m.group("head"), text)
    return REFERENCE.sub(ref, text)
