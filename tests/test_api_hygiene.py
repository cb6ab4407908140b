"""API hygiene: every module imports, ``__all__`` is right, public functions have numpydoc docstrings."""

import ast
import importlib
import inspect
import pkgutil
import textwrap

import pytest

import leakdiag

MODULES = sorted(
    m.name for m in pkgutil.walk_packages(leakdiag.__path__, prefix="leakdiag.")
    if not m.name.split(".")[-1].startswith("_")
)


@pytest.mark.parametrize("name", MODULES)
def test_module_all_is_correct(name):
    mod = importlib.import_module(name)
    names = getattr(mod, "__all__", None)
    if names is None:
        assert not [n for n, v in vars(mod).items() if not n.startswith("_")
                    and inspect.isfunction(v) and v.__module__ == name], \
            f"{name} defines public functions but no __all__"
        return
    assert len(set(names)) == len(names), f"{name}.__all__ has duplicates"
    for n in names:
        assert hasattr(mod, n), f"{name}.__all__ names {n!r} which does not exist"


def _public_functions():
    for name in MODULES:
        mod = importlib.import_module(name)
        for n in getattr(mod, "__all__", []):
            obj = getattr(mod, n)
            if inspect.isfunction(obj) and obj.__module__ == name:
                yield f"{name}.{n}", obj


@pytest.mark.parametrize("qualname,func", list(_public_functions()), ids=lambda v: v if isinstance(v, str) else "")
def test_public_function_has_numpydoc_docstring(qualname, func):
    doc = inspect.getdoc(func)
    assert doc, f"{qualname} has no docstring"
    params = [p for p in inspect.signature(func).parameters.values()
              if p.name not in ("self", "cls") and p.kind not in (p.VAR_KEYWORD,)]
    if params and not getattr(func, "__click_params__", None):
        assert "Parameters\n----------" in doc, f"{qualname} docstring lacks a Parameters section"


def _body(func) -> ast.AST:
    """The function's own AST (nested functions, lambdas and classes are not its body)."""
    return ast.parse(textwrap.dedent(inspect.getsource(func))).body[0]


def _own_nodes(fn: ast.AST):
    stack = list(ast.iter_child_nodes(fn))
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            continue
        yield node
        stack.extend(ast.iter_child_nodes(node))


def returns_value(func) -> bool:
    """True if the source has a ``return <value>`` (not bare, not ``return None``)."""
    return any(isinstance(n, ast.Return) and n.value is not None
               and not (isinstance(n.value, ast.Constant) and n.value.value is None)
               for n in _own_nodes(_body(func)))


def raises_directly(func) -> bool:
    """True if the source has its own ``raise SomeError(...)`` (not a bare re-raise)."""
    return any(isinstance(n, ast.Raise) and n.exc is not None for n in _own_nodes(_body(func)))


def test_source_inspection_helpers():
    def plain(x):
        if x:
            return None
        return

    def value(x):
        def inner():
            return 1
        return x + 1

    def nested_only(x):
        def inner():
            raise ValueError("x")
        return inner

    def reraise():
        try:
            pass
        except ValueError:
            raise

    assert not returns_value(plain) and returns_value(value) and returns_value(nested_only)
    assert not raises_directly(nested_only) and not raises_directly(reraise)
    assert raises_directly(inner_raiser)


def inner_raiser(x):
    if x < 0:
        raise ValueError(f"{x=} must be >= 0")


def _public_methods():
    """Public methods of the public classes (``__all__``) defined in leakdiag."""
    for name in MODULES:
        mod = importlib.import_module(name)
        for n in getattr(mod, "__all__", []):
            cls = getattr(mod, n)
            if not (inspect.isclass(cls) and cls.__module__ == name):
                continue
            for mname, meth in vars(cls).items():
                if not mname.startswith("_") and inspect.isfunction(meth):
                    yield f"{name}.{n}.{mname}", meth


#: Known exceptions to the Returns rule (none today). An entry must name a real gap: once its
#: docstring is fixed, test_known_gaps_are_still_gaps fails until the entry is removed.
KNOWN_MISSING_RETURNS: set[str] = set()
#: Same for Raises.
KNOWN_MISSING_RAISES: set[str] = set()


@pytest.mark.parametrize("qualname,func", list(_public_functions()) + list(_public_methods()),
                         ids=lambda v: v if isinstance(v, str) else "")
def test_returns_and_raises_sections(qualname, func):
    """A public function or method that returns a value documents it; one that raises says what."""
    doc = inspect.getdoc(func) or ""
    if returns_value(func) and qualname not in KNOWN_MISSING_RETURNS:
        assert "Returns\n-------" in doc or "Yields\n------" in doc, \
            f"{qualname} returns a value but its docstring lacks a Returns section"
    if raises_directly(func) and qualname not in KNOWN_MISSING_RAISES:
        assert "Raises\n------" in doc, \
            f"{qualname} raises but its docstring lacks a Raises section"


def test_known_gaps_are_still_gaps():
    """An allow-list entry whose docstring has been fixed must be removed from the list."""
    everything = dict(_public_functions()) | dict(_public_methods())
    for q in KNOWN_MISSING_RETURNS:
        assert q in everything and "Returns\n-------" not in (inspect.getdoc(everything[q]) or ""), q
    for q in KNOWN_MISSING_RAISES:
        assert q in everything and "Raises\n------" not in (inspect.getdoc(everything[q]) or ""), q


def test_import_leakdiag_is_light():
    import subprocess
    import sys

    code = ("import sys, leakdiag; heavy = [m for m in ('matplotlib', 'dask', 'statsmodels', "
            "'ruptures', 'pywt', 'PyEMD', 'sklearn') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import leakdiag pulls in {out.stdout.strip()}"
