"""The public API: exactly ``podid_rs.__all__``, and every part of it documented in numpydoc.

Documented means: a function has a ``Parameters`` section naming each of its
parameters and, unless it returns None, a ``Returns`` (or ``Yields``) section; a
class has ``Parameters`` or ``Attributes``, and its ``Attributes`` name each of its
public properties; every public method of a public class is documented as a
function. The sections are read by :func:`numpydoc_sections` below, not by numpydoc.
"""

from __future__ import annotations

import inspect
import re
import types

import pytest

import podid_rs

_UNDERLINE = re.compile(r"^-{3,}$")


def numpydoc_sections(doc: str | None) -> dict[str, list[str]]:
    """The sections of a numpydoc docstring: title → its lines (indentation kept).

    A section starts at a line followed by a line of dashes as long as it; the text
    before the first section is under ``""``.
    """
    lines = inspect.cleandoc(doc or "").splitlines()
    sections: dict[str, list[str]] = {"": []}
    current = ""
    i = 0
    while i < len(lines):
        title = lines[i].strip()
        under = lines[i + 1].strip() if i + 1 < len(lines) else ""
        if title and _UNDERLINE.match(under) and len(under) == len(title):
            current = title
            sections[current] = []
            i += 2
            continue
        sections[current].append(lines[i])
        i += 1
    return sections


def documented_names(section: list[str]) -> set[str]:
    """The names a ``Parameters``/``Attributes`` section documents: the unindented
    ``name, other : type`` lines (``*args``/``**kwargs`` keep no stars)."""
    names: set[str] = set()
    for line in section:
        if line and not line[0].isspace():
            head = line.split(" : ", 1)[0]
            names.update(n.strip().lstrip("*") for n in head.split(",") if n.strip())
    return names


def _returns_something(fn: object) -> bool:
    annotation = inspect.signature(fn).return_annotation
    return annotation not in (None, "None")


def _function_problems(qualname: str, fn: object, skip_first: bool = False) -> list[str]:
    sections = numpydoc_sections(inspect.getdoc(fn))
    params = list(inspect.signature(fn).parameters.values())[1 if skip_first else 0 :]
    problems = []
    if params:
        if "Parameters" not in sections:
            problems.append(f"{qualname}: no Parameters section")
        else:
            missing = {p.name for p in params} - documented_names(sections["Parameters"])
            if missing:
                problems.append(f"{qualname}: Parameters does not name {sorted(missing)}")
    if _returns_something(fn) and not {"Returns", "Yields"} & sections.keys():
        problems.append(f"{qualname}: no Returns section")
    return problems


def _public_members(cls: type) -> dict[str, object]:
    """What ``cls`` itself defines for users: public methods and properties."""
    return {
        name: value
        for name, value in vars(cls).items()
        if not name.startswith("_")
        and (inspect.isfunction(value) or isinstance(value, property | classmethod))
    }


def _class_problems(name: str, cls: type) -> list[str]:
    sections = numpydoc_sections(inspect.getdoc(cls))
    problems = []
    if not {"Parameters", "Attributes"} & sections.keys():
        problems.append(f"{name}: no Parameters or Attributes section")
    attributes = documented_names(sections.get("Attributes", []))
    for member, value in _public_members(cls).items():
        if isinstance(value, property):
            if member not in attributes:
                problems.append(f"{name}.{member}: a property not named in Attributes")
        elif isinstance(value, classmethod):
            problems += _function_problems(f"{name}.{member}", value.__func__, skip_first=True)
        else:
            problems += _function_problems(f"{name}.{member}", value, skip_first=True)
    return problems


def api_problems(module: types.ModuleType) -> list[str]:
    """Every public function, class and method of ``module.__all__`` lacking a section."""
    problems = []
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isclass(obj):
            problems += _class_problems(name, obj)
        else:
            problems += _function_problems(name, obj)
    return problems


def test_every_public_function_and_class_has_its_numpydoc_sections():
    problems = api_problems(podid_rs)
    assert not problems, "numpydoc sections missing:\n  " + "\n  ".join(problems)


def test_the_section_reader_sees_what_is_missing():
    def documented(a: int, b: int = 0) -> int:
        """Sum.

        Parameters
        ----------
        a, b : int
            The terms.

        Returns
        -------
        int
            a + b.
        """
        return a + b

    def no_returns(a: int, *, scale: float = 1.0, **kwargs: object) -> float:
        """Scaled.

        Parameters
        ----------
        a : int
            The value.
        **kwargs
            Ignored.
        """
        return a * scale

    assert _function_problems("documented", documented) == []
    assert documented_names(numpydoc_sections(no_returns.__doc__)["Parameters"]) == {
        "a",
        "kwargs",
    }
    assert _function_problems("no_returns", no_returns) == [
        "no_returns: Parameters does not name ['scale']",
        "no_returns: no Returns section",
    ]


# --------------------------------------------------------------------------- __all__


def _is_api_object(obj: object) -> bool:
    return inspect.isclass(obj) or inspect.isfunction(obj) or inspect.isbuiltin(obj)


def test_all_lists_each_public_name_once():
    names = podid_rs.__all__
    duplicates = sorted({n for n in names if names.count(n) > 1})
    assert not duplicates, f"named twice in __all__: {duplicates}"
    absent = [n for n in names if not hasattr(podid_rs, n)]
    assert not absent, f"in __all__ but not in podid_rs: {absent}"


def test_no_module_is_in_all():
    modules = [n for n in podid_rs.__all__ if isinstance(getattr(podid_rs, n), types.ModuleType)]
    assert not modules, f"modules in __all__: {modules}"
    not_api = [n for n in podid_rs.__all__ if not _is_api_object(getattr(podid_rs, n))]
    assert not not_api, f"in __all__ but neither a function nor a class: {not_api}"


def test_every_public_function_and_class_of_the_package_is_in_all():
    public = {
        name
        for name, obj in vars(podid_rs).items()
        if not name.startswith("_") and _is_api_object(obj)
    }
    assert public - set(podid_rs.__all__) == set(), "public in podid_rs but not in __all__"


@pytest.mark.parametrize("name", podid_rs.__all__)
def test_each_name_of_all_is_the_package_own(name):
    assert getattr(podid_rs, name).__module__.startswith("podid_rs."), name
