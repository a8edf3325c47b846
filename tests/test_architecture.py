"""docs/architecture.md's table of rooms against the imports fricfem's code makes
(tests/import_graph.py reads them from the source, top-level and inside functions
alike): every module of fricfem lives in a room of the table; a room imports
exactly the rooms its "imports" column names (an import not listed fails, and so
does a listed one no longer made); and no module of fricfem takes part in an
import cycle."""

import re
from pathlib import Path

import pytest

import import_graph as graph

DOC = graph.ROOT / "docs" / "architecture.md"


def _split(cell: str) -> list:
    """The comma-separated items of a cell, commas inside parentheses kept."""
    items, depth, cur = [], 0, ""
    for ch in cell:
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
        else:
            cur += ch
    return [i.strip() for i in items + [cur] if i.strip()]


def _short(path: str) -> str:
    """A room's name in the imports column: ``fricfem/model/`` -> model, ``fricfem/runner.py``
    -> runner, ``fricfem/__init__.py`` -> fricfem."""
    name = Path(path.rstrip("/")).name
    return "fricfem" if name == "__init__.py" else name.removesuffix(".py")


def parse_rooms(text: str) -> dict:
    """{room name: (set of module prefixes, set of room names it imports)} from the
    table under "## The rooms" (rows whose paths hold no fricfem module are left out)."""
    section = text.split("## The rooms", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    assert rows, "docs/architecture.md: no table of rooms under '## The rooms'"
    rooms = {}
    for line in rows:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        assert len(cells) == 3, f"docs/architecture.md: a row of the rooms' table without 3 cells: {line[:80]}"
        paths = [p for p in re.findall(r"`([^`]+)`", cells[0]) if p.startswith("fricfem/")]
        mods = set()
        for p in paths:
            rel = p.rstrip("/").removesuffix(".py").replace("/", ".")
            mods.add("fricfem" if rel == "fricfem.__init__" else rel)
        if not mods or all(not (graph.ROOT / p).exists() or (graph.ROOT / p).is_dir()
                           and not any((graph.ROOT / p).rglob("*.py")) for p in paths):
            continue
        imported = set()
        if cells[2] not in ("—", "-", ""):
            for item in _split(cells[2]):
                imported.add(re.sub(r"\s*\(.*", "", item).strip())
        rooms[_short(paths[0])] = (mods, imported, {_short(p) for p in paths})
    return rooms


def _room_of(module: str, rooms: dict) -> str | None:
    """The table's room holding ``module`` (the longest matching path), or None."""
    best = None
    for name, (mods, _, _) in rooms.items():
        for m in mods:
            if (module == m or module.startswith(m + ".")) and (m != "fricfem" or module == "fricfem"):
                if best is None or len(m) > len(best[1]):
                    best = (name, m)
    return best and best[0]


@pytest.fixture(scope="module")
def rooms():
    return parse_rooms(DOC.read_text())


@pytest.fixture(scope="module")
def imports():
    return graph.imports()


def test_every_module_lives_in_a_room_of_the_table(rooms, imports):
    homeless = sorted(m for m in imports if _room_of(m, rooms) is None)
    assert not homeless, f"modules in no room of docs/architecture.md's table: {homeless}"


def test_rooms_import_exactly_what_the_table_says(rooms, imports):
    names = {alias: name for name, (_, _, aliases) in rooms.items() for alias in aliases}
    for name, (_, listed, _) in rooms.items():
        unknown = sorted(r for r in listed if r not in names)
        assert not unknown, f"docs/architecture.md: room {name} lists {unknown}, which are no rooms of the table"
    made = {name: {} for name in rooms}
    for mod, targets in imports.items():
        a = _room_of(mod, rooms)
        for target, lines in targets.items():
            b = _room_of(target, rooms)
            if a != b:
                made[a].setdefault(b, f"{mod} imports {target} (line {lines[0][0]})")
    problems = []
    for name, (_, listed, _) in rooms.items():
        listed = {names[r] for r in listed}
        for b, where in sorted(made[name].items()):
            if b not in listed:
                problems.append(f"{name} imports {b}, which its row does not list: {where}")
        for b in sorted(listed - set(made[name])):
            problems.append(f"{name} lists {b}, which it no longer imports")
    assert not problems, "docs/architecture.md's table and the code disagree:\n" + "\n".join(problems)


def test_no_import_cycle(imports):
    cycles = graph.cycles(imports)
    assert not cycles, f"import cycles among fricfem's modules (python tests/import_graph.py): {cycles}"


def test_the_checks_see_a_cycle_and_a_wrong_row():
    """The checks themselves: a made-up cycle is found, and a table naming an import
    the code does not make (or missing one it makes) is parsed as such."""
    assert graph.cycles({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}) == [["a", "b", "c"]]
    assert graph.cycles({"a": {"b": 1}, "b": {}}) == []
    text = ("## The rooms\n\n| room | what | imports |\n|---|---|---|\n"
            "| `fricfem/keys.py` | keys | step (the step, really) |\n"
            "| `fricfem/step/` | the step | kernels, keys |\n| `fricfem/kernels/` | numba | — |\n\n## Next\n")
    rooms = parse_rooms(text)
    assert rooms["keys"][1] == {"step"} and rooms["step"][1] == {"kernels", "keys"} and rooms["kernels"][1] == set()
    assert _room_of("fricfem.step.fused", rooms) == "step" and _room_of("fricfem.runner", rooms) is None


def test_every_import_inside_a_function_says_why():
    """Issue 25: an import inside a function stays only where start-up time (or a cycle) needs
    it, with a comment saying so: on its line, or on a comment line heading its block (imports
    separated by blank lines only)."""
    import ast

    missing = []
    for path in sorted(Path(__file__).resolve().parents[1].joinpath("fricfem").rglob("*.py")):
        src = path.read_text()
        lines = src.splitlines()
        nodes = sorted({n.lineno: n for f in ast.walk(ast.parse(src))
                        if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                        for n in ast.walk(f) if isinstance(n, (ast.Import, ast.ImportFrom))}.items())
        covered = {i for _, n in nodes for i in range(n.lineno, n.end_lineno + 1)}
        for lineno, n in nodes:
            if any("#" in lines[i - 1] for i in range(n.lineno, n.end_lineno + 1)):
                continue
            i = lineno - 1                      # 1-based line above
            while i >= 1 and (i in covered or not lines[i - 1].strip()):
                i -= 1
            if i < 1 or not lines[i - 1].strip().startswith("#"):
                missing.append(f"{path.relative_to(path.parents[1])}:{lineno}: {lines[lineno - 1].strip()}")
    assert not missing, "imports inside functions without a comment saying why:\n" + "\n".join(missing)
