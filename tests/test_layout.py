"""The package's layout: no import cycle between its files, and every module says what it is.

The import graph is read from the source with :mod:`ast`, not by importing it:
every ``import`` and ``from … import`` anywhere in a file (module level, inside
functions and classes, under ``if TYPE_CHECKING``), relative or absolute, that
names a file of ``python/podid_rs/``. A function-level import counts like any
other: one that exists to dodge a cycle is still a cycle.

``from package import name`` is an edge to the file ``package/name.py`` when that
file exists, else to the package's ``__init__.py`` when it binds ``name``; a name
it does not bind is a compiled submodule (the Rust ``_core``), outside the graph.
``from module import name`` is an edge to the module.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = "podid_rs"
ROOT = Path(__file__).resolve().parents[1] / "python" / PACKAGE


def _module_name(path: Path, root: Path) -> str:
    """``podid_rs.a.b`` for ``a/b.py``, ``podid_rs.a`` for ``a/__init__.py``."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([PACKAGE, *parts])


def _modules(root: Path) -> dict[str, Path]:
    """Every Python file of the package by its dotted module name."""
    return {_module_name(p, root): p for p in sorted(root.rglob("*.py"))}


def _bound_names(tree: ast.Module) -> set[str]:
    """The names a module binds at its top level (definitions, assignments, imports)."""
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
    return names


def _imported_modules(
    name: str, path: Path, tree: ast.Module, modules: dict[str, Path], bound: dict[str, set[str]]
) -> set[str]:
    """The package's modules that ``name`` (the module in ``path``) imports anywhere."""
    is_package = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in modules:
                    out.add(alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = name.split(".")
                if not is_package:
                    parts = parts[:-1]
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join(parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base != PACKAGE and not base.startswith(PACKAGE + "."):
                continue
            for alias in node.names:
                target = f"{base}.{alias.name}"
                if target in modules:
                    out.add(target)
                elif base in modules and (
                    modules[base].name != "__init__.py"
                    or alias.name == "*"
                    or alias.name in bound[base]
                ):
                    out.add(base)
    out.discard(name)
    return out


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """File-level import graph of the package under ``root``: module → modules it imports."""
    modules = _modules(root)
    trees = {n: ast.parse(p.read_text(encoding="utf-8"), str(p)) for n, p in modules.items()}
    bound = {n: _bound_names(t) for n, t in trees.items()}
    return {n: _imported_modules(n, modules[n], trees[n], modules, bound) for n in modules}


def tangles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm):
    each module of one can reach every other of it, so each holds at least one cycle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(comp)

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return components


def shortest_cycle(graph: dict[str, set[str]], component: set[str]) -> list[str]:
    """A shortest closed path through the first module (by name) of ``component``."""
    start = min(component)
    previous: dict[str, str] = {}  # breadth-first tree: module → the one it was reached from
    frontier = [start]
    while start not in previous:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & component):
                if w not in previous:
                    previous[w] = v
                    nxt.append(w)
        frontier = nxt
    path = [start]
    while True:
        path.append(previous[path[-1]])
        if path[-1] == start:
            return path[::-1]


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle per tangle of the graph (empty when it has none)."""
    return [shortest_cycle(graph, comp) for comp in tangles(graph)]


def _file(name: str) -> str:
    path = _modules(ROOT)[name]
    return str(path.relative_to(ROOT.parent))


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert len(graph) > 10, f"found only {sorted(graph)} under {ROOT}"
    report = [
        f"  {' → '.join(_file(n) for n in shortest_cycle(graph, comp))}\n"
        f"    (one of the cycles among {', '.join(sorted(_file(n) for n in comp))})"
        for comp in tangles(graph)
    ]
    assert not report, "import cycles between files of the package:\n" + "\n".join(report)


def test_every_module_has_a_docstring():
    missing = [
        str(path.relative_to(ROOT.parent))
        for path in _modules(ROOT).values()
        if not (ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or "").strip()
    ]
    assert not missing, f"modules without a docstring of their own: {missing}"


def test_the_graph_sees_function_level_relative_and_absolute_imports(tmp_path):
    """The reader itself: a cycle hidden in a function, through a relative and an
    absolute import, a package's ``__init__`` and a compiled submodule."""
    pkg = tmp_path / PACKAGE
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text('"""p"""\nfrom .a import f\n')
    (pkg / "a.py").write_text(
        '"""a"""\nfrom . import _core\n\n\ndef f():\n    from .sub.b import g\n'
    )
    (pkg / "sub" / "__init__.py").write_text('"""s"""\n')
    (pkg / "sub" / "b.py").write_text('"""b"""\nimport podid_rs.sub\nfrom podid_rs import a\n')
    graph = import_graph(pkg)
    assert graph == {
        "podid_rs": {"podid_rs.a"},
        "podid_rs.a": {"podid_rs.sub.b"},
        "podid_rs.sub": set(),
        "podid_rs.sub.b": {"podid_rs.sub", "podid_rs.a"},
    }
    assert find_cycles(graph) == [["podid_rs.a", "podid_rs.sub.b", "podid_rs.a"]]
    (pkg / "a.py").write_text('"""a"""\n')
    assert find_cycles(import_graph(pkg)) == []


def test_one_compiled_core_beside_the_package():
    """One ``_core`` extension in the package directory: a build left over under another
    tag (``_core.cpython-311-….so`` beside the abi3 ``_core.abi3.so``) is the one Python
    loads, and the Rust edits of a new build would silently not run."""
    import podid_rs

    package = Path(podid_rs.__file__).parent
    cores = sorted(p.name for p in package.glob("_core*") if p.suffix in (".so", ".pyd"))
    assert len(cores) == 1, f"more than one compiled _core in {package}: {cores}"
