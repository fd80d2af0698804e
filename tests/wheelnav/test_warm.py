"""``wheelnav warm`` compiles every cached numba kernel of the sources into numba's cache,
and the services' own start and first step then load them instead of compiling them.

The warm-up runs once for the module, in a subprocess whose ``NUMBA_CACHE_DIR`` is a fresh
directory: it compiles everything, as on a fresh clone (about 25 s on an idle 2-core
machine, several times that on a loaded one).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from wheelnav.warm import MODULES, warm

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("services", "shared", "sim", "behaviours", "wheelnav")


def _jit_options(node: ast.expr) -> dict[str, object] | None:
    """The constant keywords of a ``numba.njit(...)`` / ``numba.jit(...)`` call, else None."""
    if not isinstance(node, ast.Call):
        return None
    name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
    if name not in ("njit", "jit"):
        return None
    return {k.arg: k.value.value for k in node.keywords if isinstance(k.value, ast.Constant)}


def kernels_in_sources() -> dict[str, list[str]]:
    """Module -> its kernels compiled with ``cache=True``, read from the sources: decorated
    functions, and ``NAME = numba.njit(cache=True)(function)`` (named after the function).
    Kernels inlined (``inline="always"``) have no cache files of their own: the module is
    listed, they are not."""
    found: dict[str, list[str]] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            kernels, cached = [], False
            for node in ast.walk(tree):
                if isinstance(node, ast.FunctionDef):
                    candidates = [(node.name, d) for d in node.decorator_list]
                elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
                    args = node.value.args
                    name = args[0].id if args and isinstance(args[0], ast.Name) else ""
                    candidates = [(name, node.value.func)]
                else:
                    continue
                for name, call in candidates:
                    options = _jit_options(call)
                    if options and options.get("cache") is True:
                        cached = True
                        if options.get("inline") != "always" and name:
                            kernels.append(name)
            if cached:
                module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
                found[module] = kernels
    return found


def _run(args: list[str], cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900
    )


@pytest.fixture(scope="module")
def warmed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess]:
    """A numba cache directory filled by ``python -m wheelnav.warm``, and that run."""
    cache = tmp_path_factory.mktemp("numba-cache")
    return cache, _run(["-m", "wheelnav.warm"], cache)


def test_the_warmed_modules_are_those_with_cached_kernels_in_the_sources() -> None:
    found = kernels_in_sources()
    assert "services.controller.mpc_numba" in found  # the scan reads the sources
    assert sorted(MODULES) == sorted(found)


# make test-long: both compile the whole stack cold (25 s idle, minutes loaded); in make
# test the module list above and the failure test below, and .ci/run runs `make warm`
@pytest.mark.long
def test_warm_fills_the_cache_with_every_kernel_and_names_every_module(warmed) -> None:
    cache, run = warmed
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert f"total: {len(MODULES)} of {len(MODULES)} modules" in lines[-1]
    missing = []
    for module, kernels in kernels_in_sources().items():
        assert [line for line in lines if f" {module} " in line and " compiled" in line], module
        stem = module.rsplit(".", 1)[-1]
        for kernel in kernels:
            for suffix in ("nbi", "nbc"):
                if not list(cache.rglob(f"{stem}.{kernel}-*.{suffix}")):
                    missing.append(f"{module}.{kernel} (.{suffix})")
    assert not missing, f"no cache file for {missing}"


@pytest.mark.long
def test_the_services_load_their_kernels_from_the_warmed_cache(warmed) -> None:
    cache, run = warmed
    assert run.returncode == 0, run.stderr
    modules = sorted(kernels_in_sources())
    probe = _run(["-m", "tests.wheelnav.warm_probe", *modules], cache)
    assert probe.returncode == 0, probe.stderr
    stats = json.loads(probe.stdout.strip().splitlines()[-1])
    compiled = {kernel: s["misses"] for kernel, s in stats.items() if s["misses"]}
    assert not compiled, f"compiled at start, not found in the cache: {compiled}"
    loaded = {kernel.rsplit(".", 1)[0] for kernel, s in stats.items() if s["hits"]}
    assert sorted(loaded) == modules


def test_a_module_whose_kernel_fails_is_named_on_one_line_and_the_exit_is_1(
    monkeypatch, capsys
) -> None:
    import numba

    def broken() -> None:
        numba.njit(lambda x: x + "text")(1)

    for name, warm_up in (("broken_kernels", broken), ("idle_kernels", lambda: None)):
        module = types.ModuleType(name)
        module.warm_up = warm_up
        monkeypatch.setitem(sys.modules, name, module)
    assert warm(("broken_kernels", "idle_kernels")) == 1
    out, err = capsys.readouterr()
    errors = err.strip().splitlines()
    assert errors[0].startswith("wheelnav warm: broken_kernels: kernel failed to compile: ")
    assert "TypingError" in errors[0]
    assert errors[1] == "wheelnav warm: idle_kernels: warm_up() ran none of its kernels"
    assert "total: 0 of 2 modules" in out


def test_warm_is_a_wheelnav_command(capsys) -> None:
    from wheelnav.cli import main

    with pytest.raises(SystemExit):
        main(["--help"])
    assert "wheelnav warm" in capsys.readouterr().out
