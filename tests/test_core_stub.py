"""The stub ``python/podid_rs/_core.pyi`` describes the compiled module exactly.

Read with :mod:`ast` and compared with the module itself: the same public names;
for every function and method the same parameters (names, kinds, defaults); for
every class the same read-only attributes, methods and constructor; and on small
calls, every attribute and return value of the type the stub declares. A binding
added, renamed or retyped without its stub (or the other way round) fails here.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

import podid_rs
from podid_rs import _core

STUB = Path(podid_rs.__file__).with_name("_core.pyi")

#: the stub's array aliases: (dtype, number of dimensions)
ARRAYS = {
    "_Float1": (np.float64, 1),
    "_Float2": (np.float64, 2),
    "_Complex2": (np.complex128, 2),
}
#: the stub's other private aliases, by what they stand for
ALIASES = {"_Triple", "_Progress"}


def _stub() -> ast.Module:
    return ast.parse(STUB.read_text(encoding="utf-8"))


def _top_level(tree: ast.Module) -> dict[str, ast.AST]:
    out: dict[str, ast.AST] = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            out[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = node
        elif isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    out[target.id] = node
    return out


def _public(name: str) -> bool:
    return not name.startswith("_") or name == "__version__"


def _is_property(node: ast.FunctionDef) -> bool:
    return any(isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list)


def _members(cls: ast.ClassDef) -> dict[str, ast.FunctionDef]:
    return {n.name: n for n in cls.body if isinstance(n, ast.FunctionDef)}


def _stub_parameters(fn: ast.FunctionDef, method: bool) -> list[tuple[str, str, object]]:
    """(name, kind, default) of each parameter, `self` left out; default is
    `inspect.Parameter.empty` where there is none."""
    a = fn.args
    positional = a.posonlyargs + a.args
    if method:
        positional = positional[1:]
    defaults = [inspect.Parameter.empty] * (len(positional) - len(a.defaults))
    defaults += [ast.literal_eval(d) for d in a.defaults]
    out = [(p.arg, "positional", d) for p, d in zip(positional, defaults, strict=True)]
    for p, d in zip(a.kwonlyargs, a.kw_defaults, strict=True):
        default = inspect.Parameter.empty if d is None else ast.literal_eval(d)
        out.append((p.arg, "keyword", default))
    return out


def _runtime_parameters(sig: inspect.Signature) -> list[tuple[str, str, object]]:
    kinds = {
        inspect.Parameter.POSITIONAL_ONLY: "positional",
        inspect.Parameter.POSITIONAL_OR_KEYWORD: "positional",
        inspect.Parameter.KEYWORD_ONLY: "keyword",
    }
    return [
        (p.name, kinds[p.kind], p.default)
        for p in sig.parameters.values()
        if p.name != "self"
    ]


def test_the_stub_and_the_module_have_the_same_names():
    stub = {n for n in _top_level(_stub()) if _public(n)}
    module = {n for n in dir(_core) if _public(n)}
    assert stub - module == set(), "in the stub, not in _core"
    assert module - stub == set(), "in _core, not in the stub"


def test_the_stubs_private_aliases_are_the_ones_this_test_knows():
    private = {n for n in _top_level(_stub()) if not _public(n)}
    assert private == set(ARRAYS) | ALIASES


def test_every_function_has_the_stubs_parameters():
    for name, node in _top_level(_stub()).items():
        if isinstance(node, ast.FunctionDef):
            sig = inspect.signature(getattr(_core, name))
            assert _runtime_parameters(sig) == _stub_parameters(node, method=False), name


def test_every_class_has_the_stubs_attributes_methods_and_constructor():
    for name, node in _top_level(_stub()).items():
        if not isinstance(node, ast.ClassDef):
            continue
        cls = getattr(_core, name)
        members = _members(node)
        runtime = {n: v for n, v in vars(cls).items() if not n.startswith("_")}
        attributes = {n for n, v in runtime.items() if inspect.isdatadescriptor(v)}
        methods = {n for n, v in runtime.items() if callable(v)}
        assert attributes | methods == set(runtime), name
        assert attributes == {n for n, f in members.items() if _is_property(f)}, name
        stub_methods = {n for n, f in members.items() if not _is_property(f)} - {"__init__"}
        assert methods == stub_methods, name
        for method in methods:
            sig = inspect.signature(getattr(cls, method))
            assert _runtime_parameters(sig) == _stub_parameters(members[method], True), (
                f"{name}.{method}"
            )
        # a constructor in the stub exactly where the class has one
        assert ("__init__" in members) == (cls.__text_signature__ is not None), name
        if "__init__" in members:
            sig = inspect.signature(cls)
            assert _runtime_parameters(sig) == _stub_parameters(members["__init__"], True), name


# ---------------------------------------------------------------------------
# the declared types, on small calls


def _matches(value: object, ann: ast.expr) -> bool:
    """Whether `value` is of the stub's annotation `ann` (the forms the stub uses)."""
    if isinstance(ann, ast.Constant) and ann.value is None:
        return value is None
    if isinstance(ann, ast.BinOp) and isinstance(ann.op, ast.BitOr):
        return _matches(value, ann.left) or _matches(value, ann.right)
    if isinstance(ann, ast.Name):
        if ann.id in ARRAYS:
            dtype, ndim = ARRAYS[ann.id]
            return isinstance(value, np.ndarray) and value.dtype == dtype and value.ndim == ndim
        if ann.id == "_Triple":
            return isinstance(value, tuple) and len(value) == 3 and all(
                type(v) is float for v in value
            )
        scalar = {"int": int, "float": float, "str": str, "bool": bool}
        if ann.id in scalar:
            return type(value) is scalar[ann.id]
        return isinstance(value, getattr(_core, ann.id))
    if isinstance(ann, ast.Subscript) and isinstance(ann.value, ast.Name):
        args = ann.slice.elts if isinstance(ann.slice, ast.Tuple) else [ann.slice]
        if ann.value.id == "tuple":
            return (
                isinstance(value, tuple)
                and len(value) == len(args)
                and all(_matches(v, a) for v, a in zip(value, args, strict=True))
            )
        if ann.value.id == "list":
            return isinstance(value, list) and all(_matches(v, args[0]) for v in value)
        if ann.value.id == "dict":
            return isinstance(value, dict) and all(
                _matches(k, args[0]) and _matches(v, args[1]) for k, v in value.items()
            )
    raise AssertionError(f"the test does not know the annotation {ast.unparse(ann)}")


def _assert_attributes(obj: object) -> None:
    cls = _top_level(_stub())[type(obj).__name__]
    assert isinstance(cls, ast.ClassDef)
    for name, fn in _members(cls).items():
        if _is_property(fn):
            value = getattr(obj, name)
            assert fn.returns is not None
            assert _matches(value, fn.returns), (
                f"{type(obj).__name__}.{name} = {value!r} is not {ast.unparse(fn.returns)}"
            )


def _assert_returns(name: str, value: object) -> None:
    node = _top_level(_stub())[name]
    assert isinstance(node, ast.FunctionDef) and node.returns is not None
    assert _matches(value, node.returns), f"{name} returned {value!r}"


@pytest.fixture(scope="module")
def data():
    """A stable 3-DOF system on 12 lines, one load case each: (M, C, K), u, f, ω."""
    rng = np.random.default_rng(0)
    m, s = 3, 12
    A = rng.standard_normal((m, m))
    M = np.eye(m) + 0.1 * (A @ A.T)
    K = np.diag([4.0, 9.0, 16.0]) + 0.5 * np.eye(m)
    C = 0.05 * M + 0.01 * K
    omega = np.linspace(0.5, 5.0, s)
    f = rng.standard_normal((s, m)) + 1j * rng.standard_normal((s, m))
    u = np.stack([np.linalg.solve(-w * w * M + 1j * w * C + K, f[i]) for i, w in enumerate(omega)])
    return (M, C, K), np.ascontiguousarray(u), np.ascontiguousarray(f), omega


def test_the_identification_and_its_memory_have_the_declared_types(data):
    _, u, f, omega = data
    m = u.shape[1]
    _assert_returns("gram", _core.gram(u, f, omega))
    direct = _core.identify_direct(u, f, omega, (0.0, 0.0, 0.0), False)
    _assert_returns("identify_direct", direct)
    _assert_attributes(direct)
    assert direct.iterations is None and direct.converged is None
    seen = []
    cg = _core.identify_cg(
        u, f, omega, (1.0, 1.0, 1.0), False, 1e-10, 200, progress=lambda i, r: seen.append(i)
    )
    _assert_returns("identify_cg", cg)
    _assert_attributes(cg)
    assert cg.method == "cg" and cg.iterations is not None and seen
    for name, args in (
        ("direct_memory_bytes", (m, (0.0, 0.0, 0.0), False)),
        ("cg_memory_bytes", (m, True)),
        ("sweep_memory_bytes", (m,)),
        ("operator_gemm_gflops", (8, 1)),
    ):
        _assert_returns(name, getattr(_core, name)(*args))


def test_the_lambda_sweep_has_the_declared_types(data):
    _, u, f, omega = data
    sweep = _core.lambda_sweep(u, f, omega)
    _assert_returns("lambda_sweep", sweep)
    assert sweep is not None
    _assert_attributes(sweep)
    lams = np.array([0.0, 0.1, 10.0])
    for exact in (False, True):
        points = sweep.curve(lams, exact=exact)
        _assert_attributes(points)
        assert points.gcv.shape == lams.shape
    solved = sweep.solve(1.0)
    assert isinstance(solved, tuple) and len(solved) == 3
    assert all(X.shape == (3, 3) and X.dtype == np.float64 for X in solved)


def test_the_refinement_has_the_declared_types(data):
    (M, C, K), u, f, omega = data
    s, m = u.shape
    start = tuple(np.ascontiguousarray(X * 1.01) for X in (M, C, K))
    options = _core.RefineOptions(max_iter=3)
    _assert_attributes(options)
    assert (options.max_iter, options.solver) == (3, "auto")
    eye = np.tile(np.eye(m).ravel(), (s, 1))
    weightings = (
        _core.ColumnWeights(np.ones(s)),
        _core.MatrixWeights(np.ascontiguousarray(eye)),
        _core.LogMagnitudeWeights(np.eye(m), u, np.ones((s, m))),
    )
    for weighting in weightings:
        _assert_attributes(weighting)
        out = _core.refine_output_error(u, f, omega, 1, start, weighting, options)
        _assert_returns("refine_output_error", out)
        _assert_attributes(out)
        assert out.responses.shape == (s, m)
    with pytest.raises(ValueError, match="weighting must be"):
        _core.refine_output_error(u, f, omega, 1, start, np.ones(s), options)
    with pytest.raises(ValueError, match="solver must be"):
        _core.RefineOptions(solver="sparse")
