"""API hygiene: every module imports, ``__all__`` is right, public functions have numpydoc docstrings."""

import importlib
import inspect
import pkgutil

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


def test_import_leakdiag_is_light():
    import subprocess
    import sys

    code = ("import sys, leakdiag; heavy = [m for m in ('matplotlib', 'dask', 'statsmodels', "
            "'ruptures', 'pywt', 'PyEMD', 'sklearn') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import leakdiag pulls in {out.stdout.strip()}"
