"""The import graph of fricfem's modules, read from the source (``ast``, nothing is
imported): every ``import`` / ``from ... import`` of a fricfem module, at the top
of a file or inside a function alike, and the cycles in it.

    .venv/bin/python tests/import_graph.py            # cycles (none: exit 0)
    .venv/bin/python tests/import_graph.py --rooms    # which room imports which
    .venv/bin/python tests/import_graph.py --inner    # the imports made inside functions

tests/test_architecture.py holds docs/architecture.md's table of rooms against it.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fricfem"


def modules(package: Path = PACKAGE) -> dict:
    """{dotted module name: path} of every .py file of the package (a package by its name)."""
    out = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _targets(module: str, is_package: bool, node, known: dict) -> list:
    """The fricfem modules an import statement names (a ``from X import name`` of a
    submodule names the submodule, of anything else the module X)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.split(".")[0] == "fricfem"]
    if node.level:
        base = module.split(".") if is_package else module.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
        if target.split(".")[0] != "fricfem":
            return []
    return [f"{target}.{a.name}" if f"{target}.{a.name}" in known else target for a in node.names]


def imports(package: Path = PACKAGE) -> dict:
    """{module: {imported module: [(line, inside a function), ...]}} over fricfem's
    modules (``if TYPE_CHECKING:`` blocks left out: they run no import)."""
    known = modules(package)
    graph = {m: {} for m in known}
    for mod, path in known.items():
        tree = ast.parse(path.read_text(), str(path))
        is_package = path.name == "__init__.py"

        def visit(node, inside: bool):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                    continue
                deeper = inside or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    for target in _targets(mod, is_package, child, known):
                        if target in known and target != mod:
                            graph[mod].setdefault(target, []).append((child.lineno, deeper))
                visit(child, deeper)

        visit(tree, False)
    return graph


def cycles(graph: dict) -> list:
    """The strongly connected components of more than one node (each a sorted list), or
    a node importing itself: every import cycle, by Tarjan's algorithm (iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph.get(root, ())))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(graph.get(w, ()))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1 or v in graph.get(v, ()):
                        out.append(sorted(comp))
    return out


def room_of(module: str, package: Path = PACKAGE) -> str:
    """A module's room: its sub-package of fricfem (``fricfem.model``), else itself."""
    parts = module.split(".")
    if len(parts) >= 2 and (package / parts[1]).is_dir():
        return ".".join(parts[:2])
    return module


def room_imports(graph: dict) -> dict:
    """{room: {room it imports: [(module, imported module, line), ...]}}, between rooms only."""
    out = {}
    for mod, targets in graph.items():
        for target, lines in targets.items():
            a, b = room_of(mod), room_of(target)
            if a != b:
                out.setdefault(a, {}).setdefault(b, []).append((mod, target, lines[0][0]))
    return out


def main(argv) -> int:
    graph = imports()
    if "--rooms" in argv:
        for room, targets in sorted(room_imports(graph).items()):
            print(f"{room} -> {', '.join(sorted(targets))}")
    if "--inner" in argv:
        for mod, targets in sorted(graph.items()):
            for target, lines in sorted(targets.items()):
                for line, inside in lines:
                    if inside:
                        print(f"{modules()[mod].relative_to(ROOT)}:{line}: {target}")
    found = cycles(graph)
    for comp in found:
        print("import cycle:", " <-> ".join(comp))
        for a in comp:
            for b, lines in graph[a].items():
                if b in comp:
                    print(f"    {a} -> {b} (line {', '.join(str(n) for n, _ in lines)})")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
