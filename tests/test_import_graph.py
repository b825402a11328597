"""The import graph of ``gyrocomp/`` has no cycle, and no private name crosses a package (issue 36).

The graph is read from the source with :mod:`ast`, so it holds every import:
module level, inside functions (lazy imports that keep ``--help`` fast) and
under ``TYPE_CHECKING``. Importing ``a.b.c`` from outside ``a.b`` also runs
``a.b/__init__.py`` first, so that counts as an edge to ``a.b`` too (this is
how ``commands/train`` importing ``batch.backends`` closed a circle through
``batch/__init__`` → ``batch.jobs`` → ``commands``). Cycles are the strongly
connected components of the graph (:func:`scipy.sparse.csgraph.connected_components`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

PACKAGE = Path(__file__).resolve().parents[1] / "gyrocomp"


def modules(root: Path = PACKAGE) -> dict[str, Path]:
    """Dotted module name → file, packages named by their folder."""
    found = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def imports(root: Path = PACKAGE) -> list[tuple[str, str, str, int]]:
    """``(importer, imported module, imported name or "", line)`` for every import of a module of `root`'s package."""
    mods = modules(root)

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    found = []
    for module, path in mods.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [(alias.name, "") for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(parent + ([node.module] if node.module else []))
                targets = [(f"{base}.{a.name}", "") if f"{base}.{a.name}" in mods else (base, a.name) for a in node.names]
            else:
                continue
            for name, attribute in targets:
                target = resolve(name)
                if target is not None and target != module:
                    found.append((module, target, attribute, node.lineno))
    return found


def edges(root: Path = PACKAGE) -> set[tuple[str, str]]:
    """Module → module it runs on import: the imported module and the packages around it that the importer is not in."""
    mods = modules(root)
    out = set()
    for module, target, _, _ in imports(root):
        out.add((module, target))
        parts = target.split(".")
        for k in range(1, len(parts)):
            package = ".".join(parts[:k])
            if package in mods and not (module == package or module.startswith(package + ".")):
                out.add((module, package))
    return out


def cycles(root: Path = PACKAGE) -> list[list[str]]:
    """The groups of modules that import each other in a circle (strongly connected, more than one)."""
    names = sorted(modules(root))
    index = {name: i for i, name in enumerate(names)}
    pairs = np.array([(index[a], index[b]) for a, b in edges(root)]).reshape(-1, 2)
    graph = csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(names), len(names)))
    n, labels = connected_components(graph, directed=True, connection="strong")
    groups = [[names[i] for i in np.flatnonzero(labels == k)] for k in range(n)]
    return [g for g in groups if len(g) > 1]


def private_crossings(root: Path = PACKAGE) -> list[str]:
    """Imports of a ``_name`` (module or attribute) from outside the package it lives in."""
    mods = modules(root)

    def package_of(module: str) -> str:
        return module if mods[module].name == "__init__.py" else module.rpartition(".")[0]

    found = []
    for module, target, attribute, line in imports(root):
        name = attribute or target.rpartition(".")[2]
        if not name.startswith("_") or name.startswith("__"):
            continue
        home = package_of(target) if attribute else target.rpartition(".")[0]
        here = package_of(module)
        if here != home and not here.startswith(home + "."):
            found.append(f"{module} line {line}: {target}{'.' + attribute if attribute else ''}")
    return found


def test_no_import_cycle_in_gyrocomp():
    assert cycles() == []


def test_no_private_name_imported_across_packages():
    """``_name`` may be imported only inside its own package (plots took ``diagnose.report._fmt``)."""
    assert private_crossings() == []


def test_the_checks_see_a_cycle_and_a_private_import(tmp_path):
    """Constructed package: a lazy import closing a circle through a package ``__init__``, and a private import."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from pkg import _own\n")
    (pkg / "_own.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from pkg.sub import worker\n")
    (pkg / "sub" / "worker.py").write_text("from pkg import top\nfrom pkg.sub.other import _helper\n")
    (pkg / "top.py").write_text("def f():\n    from pkg.sub.other import _helper\n")
    (pkg / "sub" / "other.py").write_text("_helper = 1\n")
    assert cycles(pkg) == [["pkg.sub", "pkg.sub.worker", "pkg.top"]]
    assert private_crossings(pkg) == ["pkg.top line 2: pkg.sub.other._helper"]
