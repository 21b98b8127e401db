"""The Rust crate's layout: no module cycle, no file too long, every file documented.

The module graph is read from the source (``rust/src``): one node per file, and
A → B when A names B — ``use crate::b…``, a ``crate::b::…`` or ``super::b…``
path, or a path through a child module A declares. Test code is left out: the
``#[cfg(test)]`` items, and the files that hold only tests (declared
``#[cfg(test)] mod tests;``). Comments (doc links included) are not references.
A file's parent module counts like any other: a child that uses its parent's
items while the parent uses the child's is a cycle. The cycles are found as in
``test_layout.py``, which checks the Python package the same way.
"""

from __future__ import annotations

import re
from pathlib import Path

from test_layout import tangles

SRC = Path(__file__).resolve().parents[1] / "rust" / "src"

#: the most lines a file that is not test code may have
MAX_LINES = 800

Module = tuple[str, ...]


def _module_of(path: Path, src: Path) -> Module:
    parts = path.relative_to(src).with_suffix("").parts
    return parts[:-1] if parts[-1] in ("mod", "lib") else parts


def _strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    lines = []
    for line in text.splitlines():
        in_string = False
        for i, c in enumerate(line):
            if c == '"' and (i == 0 or line[i - 1] != "\\"):
                in_string = not in_string
            elif not in_string and line.startswith("//", i):
                line = line[:i]
                break
        lines.append(line)
    return "\n".join(lines)


def _strip_tests(text: str) -> tuple[str, set[str]]:
    """The text without its ``#[cfg(test)]`` items, and the names of the test-only
    modules it declares (``#[cfg(test)] mod x;``)."""
    test_modules: set[str] = set()
    while m := re.search(r"#\[cfg\(test\)\]", text):
        rest = text[m.end() :]
        declared = re.match(r"\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", rest)
        if declared:
            test_modules.add(declared.group(1))
            text = text[: m.start()] + rest[declared.end() :]
            continue
        text = text[: m.start()] + rest[_item_end(rest) :]
    return text, test_modules


def _item_end(text: str) -> int:
    """Where the item at the start of ``text`` ends: after its ``;`` or its balanced
    ``{ … }``."""
    depth = 0
    for i, c in enumerate(text):
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return i + 1
        elif c == ";" and depth == 0:
            return i + 1
    return len(text)


def _use_paths(tree: str) -> list[str]:
    """``a::{b, c::{d}}`` → ``a::b``, ``a::c::d``."""
    tree = tree.strip()
    if "{" not in tree:
        return [tree.split(" as ")[0].strip()]
    i = tree.index("{")
    prefix, body = tree[:i], tree[i + 1 : tree.rindex("}")]
    parts, depth, current = [], 0, ""
    for c in body:
        if c == "," and depth == 0:
            parts.append(current)
            current = ""
            continue
        depth += (c == "{") - (c == "}")
        current += c
    parts.append(current)
    return [prefix + p for part in parts if part.strip() for p in _use_paths(part)]


def _sources(src: Path) -> tuple[dict[Module, Path], dict[Module, str], set[Module]]:
    """Each module's file, its code without comments and tests, and the test-only
    modules."""
    files = {_module_of(p, src): p for p in sorted(src.rglob("*.rs"))}
    code: dict[Module, str] = {}
    declared_tests: set[Module] = set()
    for module, path in files.items():
        text, tests = _strip_tests(_strip_comments(path.read_text(encoding="utf-8")))
        code[module] = text
        declared_tests |= {module + (t,) for t in tests}
    test_only = {
        m for m in files if any(m[: len(t)] == t for t in declared_tests)
    }
    return files, code, test_only


def module_graph(src: Path = SRC) -> dict[str, set[str]]:
    """File → files it refers to (paths relative to ``src``), test code left out."""
    files, code, test_only = _sources(src)

    def resolve(here: Module, path: str, children: set[str]) -> Module | None:
        segments = [s.strip() for s in path.split("::") if s.strip()]
        if not segments:
            return None
        if segments[0] == "crate":
            base, segments = (), segments[1:]
        elif segments[0] in ("super", "self"):
            base = here
            while segments and segments[0] in ("super", "self"):
                base = base[:-1] if segments[0] == "super" else base
                segments = segments[1:]
        elif segments[0] in children:
            base = here
        else:
            return None
        for s in segments:
            if base + (s,) not in files:
                break
            base = base + (s,)
        return base if base in files else None

    graph: dict[str, set[str]] = {}
    for here, text in code.items():
        if here in test_only:
            continue
        children = set(re.findall(r"\bmod\s+(\w+)\s*;", text))
        paths = [p for u in re.findall(r"\buse\s+([^;]+);", text) for p in _use_paths(u)]
        rest = re.sub(r"\buse\s+[^;]+;", "", text)
        paths += re.findall(r"(?<![:\w])(\w+(?:::\w+)+)", rest)
        targets = {resolve(here, " ".join(p.split()), children) for p in paths}
        name = str(files[here].relative_to(src))
        graph[name] = {
            str(files[t].relative_to(src))
            for t in targets
            if t is not None and t != here and t not in test_only
        }
    return graph


def test_the_crate_has_no_module_cycle():
    graph = module_graph()
    assert len(graph) > 20  # the graph was read at all
    assert tangles(graph) == []


def test_a_cycle_would_be_found(tmp_path: Path):
    # a parent that uses its child while the child uses the parent's items
    (tmp_path / "a").mkdir()
    (tmp_path / "lib.rs").write_text("pub mod a;\n")
    (tmp_path / "a" / "mod.rs").write_text("mod b;\nuse b::Thing;\npub struct Other;\n")
    (tmp_path / "a" / "b.rs").write_text("use super::Other;\npub struct Thing;\n")
    (tmp_path / "c.rs").write_text(
        "//! c\nuse crate::a::Other;\n#[cfg(test)]\nmod tests {\n    use crate::c;\n}\n"
    )
    graph = module_graph(tmp_path)
    assert graph["c.rs"] == {"a/mod.rs"}
    assert tangles(graph) == [{"a/mod.rs", "a/b.rs"}]


def test_no_file_that_is_not_test_code_is_too_long():
    files, _, test_only = _sources(SRC)
    long = {
        str(path.relative_to(SRC)): n
        for module, path in files.items()
        if module not in test_only
        and (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}


def test_every_file_says_what_it_is_for():
    undocumented = [
        str(p.relative_to(SRC))
        for p in sorted(SRC.rglob("*.rs"))
        if not p.read_text(encoding="utf-8").lstrip().startswith("//!")
    ]
    assert undocumented == []
