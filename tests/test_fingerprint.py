"""Code fingerprints and the folder of Numba's compiled kernels (leakdiag._fingerprint,
leakdiag._numba_cache): an edit of code a kernel can reach must never run its old machine code."""

import ast
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

import leakdiag._fingerprint as F
import leakdiag._numba_cache as N

ROOT = F.PACKAGE_ROOT


def _part_of(module: str) -> str:
    """The part of the package (KERNEL_PARTS vocabulary) a ``leakdiag.x.y`` module lies in."""
    top = module.split(".")[1]
    return top if (ROOT / top).is_dir() else top + ".py"


def _leakdiag_imports(path: Path) -> set[str]:
    """Modules of leakdiag a source file imports (at any level of the file)."""
    mods = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "leakdiag":
                mods |= {f"leakdiag.{a.name}" for a in node.names}
            elif node.module.startswith("leakdiag."):
                mods.add(node.module)
        elif isinstance(node, ast.Import):
            mods |= {a.name for a in node.names if a.name.startswith("leakdiag.")}
    return mods


def _closure(parts) -> set[str]:
    """Parts reached from ``parts`` by following imports (transitively)."""
    seen, todo = set(), list(parts)
    while todo:
        part = todo.pop()
        if part in seen:
            continue
        seen.add(part)
        p = ROOT / part
        for f in ([p] if p.is_file() else p.rglob("*.py")):
            todo += [_part_of(m) for m in _leakdiag_imports(f)]
    return seen


# parts that hold no kernel code and cannot change a kernel: the version number, the two
# modules that name the cache folder itself, and the writing of instants as text (_format)
_NEUTRAL = {"_version.py", "_fingerprint.py", "_numba_cache.py", "_format.py"}


def test_every_module_that_imports_numba_lies_in_the_kernel_parts():
    users = set()
    for f in ROOT.rglob("*.py"):
        src = f.read_text()
        if "import numba" in src or "from numba" in src:
            users.add(_part_of("leakdiag." + f.relative_to(ROOT).with_suffix("").as_posix()
                               .replace("/", ".")))
    assert users and users <= set(F.KERNEL_PARTS), users - set(F.KERNEL_PARTS)


def test_the_kernel_parts_hold_everything_the_kernels_import():
    assert _closure(F.KERNEL_PARTS) - _NEUTRAL == set(F.KERNEL_PARTS)


def test_the_simulation_cache_parts_hold_everything_the_simulators_import():
    from leakdiag.runtime.cache import SIM_CODE_PARTS

    assert _closure(("sim",)) - _NEUTRAL <= set(SIM_CODE_PARTS)


@pytest.fixture
def package_copy(tmp_path, monkeypatch):
    """A copy of the package's sources that the fingerprints read instead of the real one."""
    copy = tmp_path / "leakdiag"
    shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(F, "PACKAGE_ROOT", copy)
    monkeypatch.setattr(N, "PACKAGE_ROOT", copy)
    F.parts_fingerprint.cache_clear()
    yield copy
    F.parts_fingerprint.cache_clear()


@pytest.mark.parametrize("edited", ["sim/leak.py", "features/_kernels/values.py",
                                    "_validation.py", "io/recording.py"])
def test_an_edit_a_kernel_can_reach_names_another_cache_folder(package_copy, edited):
    env = {"NUMBA_CACHE_DIR": "/somewhere"}
    before = N.kernel_cache_dir(env)
    with open(package_copy / edited, "a") as f:
        f.write("\n# an edit\n")
    F.parts_fingerprint.cache_clear()
    after = N.kernel_cache_dir(env)
    assert after != before and after.parent == before.parent == Path("/somewhere")


def test_an_edit_elsewhere_keeps_the_folder(package_copy):
    before = N.kernel_cache_dir({})
    with open(package_copy / "cli" / "main.py", "a") as f:
        f.write("\n# an edit\n")
    F.parts_fingerprint.cache_clear()
    assert N.kernel_cache_dir({}) == before
    assert before.parent == package_copy / "__pycache__" / "numba"


def test_a_missing_part_is_refused():
    with pytest.raises(ValueError, match="no module or folder 'nope'"):
        F.parts_fingerprint(("nope",))


def test_the_folder_a_parent_process_set_is_replaced_by_this_codes():
    d = N.kernel_cache_dir({"NUMBA_CACHE_DIR": "/x/leakdiag-0123456789abcdef"})
    assert d.parent == Path("/x") and d.name == f"leakdiag-{F.parts_fingerprint(F.KERNEL_PARTS)}"
    assert d.name != "leakdiag-0123456789abcdef"


def test_numba_compiles_leakdiag_kernels_into_the_folder_of_this_code():
    import numba.core.config

    from leakdiag.features._kernels import smalllag

    d = N.kernel_cache_dir()
    assert os.environ["NUMBA_CACHE_DIR"] == str(d) == numba.core.config.CACHE_DIR
    cached = [k for k in vars(smalllag).values() if getattr(k, "_cache", None) is not None
              and hasattr(k._cache, "_cache_path")]
    assert cached and all(Path(k._cache._cache_path).parent == d for k in cached)


def test_old_folders_are_pruned_beyond_the_kept_ones(tmp_path):
    keep = tmp_path / "leakdiag-ffffffffffffffff"
    keep.mkdir()
    old = []
    for i in range(N.KEEP + 2):
        d = tmp_path / f"leakdiag-{i:016x}"
        d.mkdir()
        t = time.time() - N.PRUNE_AFTER_S - 100 * (i + 1)  # older and older
        os.utime(d, (t, t))
        old.append(d)
    recent = tmp_path / "leakdiag-eeeeeeeeeeeeeeee"  # the most recently used other folder
    recent.mkdir()
    other = tmp_path / "not-ours"
    other.mkdir()
    N._prune(tmp_path, keep)
    left = sorted(p.name for p in tmp_path.iterdir())
    # kept: this code's, the KEEP most recent of the others (recent + the first KEEP-1 old),
    # and what is not a leakdiag folder
    expect = sorted([keep.name, recent.name, other.name] + [d.name for d in old[:N.KEEP - 1]])
    assert left == expect


def test_a_child_process_uses_the_same_folder(tmp_path):
    out = subprocess.run([sys.executable, "-c", "import os, leakdiag.sim; "
                          "print(os.environ['NUMBA_CACHE_DIR'])"],
                         capture_output=True, text=True, check=True,
                         env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "mine")})
    assert Path(out.stdout.strip()) == N.kernel_cache_dir({"NUMBA_CACHE_DIR": str(tmp_path / "mine")})


def _fake_leakdiag_sim(n, seed):
    import numpy as np

    from leakdiag.io.recording import Recording

    return Recording({"p1": np.arange(n, dtype=float) + seed}, 10.0)


_fake_leakdiag_sim.__module__ = "leakdiag.sim.fake"  # keyed as one of leakdiag's simulators


def test_an_edit_of_the_argument_checks_misses_the_simulation_cache(package_copy, tmp_path):
    # before 2026-11-27 the key hashed sim/ only: this edit was served the former recording
    from leakdiag.runtime.cache import cached_simulation

    kw = dict(simulator=_fake_leakdiag_sim, cache_dir=tmp_path / "c", n=5, seed=1)
    a = cached_simulation("fake", **kw)
    assert cached_simulation("fake", **kw).meta["cache_hit"] is True
    with open(package_copy / "_validation.py", "a") as f:
        f.write("\n# an edit\n")
    F.parts_fingerprint.cache_clear()
    b = cached_simulation("fake", **kw)
    assert b.meta["cache_hit"] is False and b.meta["cache_key"] != a.meta["cache_key"]


def test_other_library_versions_miss_the_simulation_cache(tmp_path, monkeypatch):
    import leakdiag.runtime.cache as C

    kw = dict(simulator=_fake_leakdiag_sim, cache_dir=tmp_path / "c", n=5, seed=1)
    a = C.cached_simulation("fake", **kw)
    monkeypatch.setattr(C, "library_versions", lambda: {**F.library_versions(), "numpy": "9.9"})
    b = C.cached_simulation("fake", **kw)
    assert b.meta["cache_hit"] is False and b.meta["cache_key"] != a.meta["cache_key"]
