"""A package exported once per session and its library built once: the tests of ``hitchpark export`` and ``sil``."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from hitchpark.app.export import ExportSpec, package_files
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.native import resolved_compiler


def compiler_or_skip() -> str:
    compiler = resolved_compiler()
    if compiler is None:
        pytest.skip("no C compiler on this machine ($CC, else gcc): the exported package is not built")
    return compiler


@pytest.fixture(scope="session")
def c_compiler() -> str:
    """The system's C compiler (the test skips, saying so, where there is none)."""
    return compiler_or_skip()


@pytest.fixture(scope="session")
def random_spec() -> ExportSpec:
    """The package of the default full-model NMPC, its example from the paper's random scenario (ideal plant)."""
    sc = builtin_scenario("random")
    return ExportSpec(sc.vehicle, start=sc.start, goal=sc.goal, plant=sc.plant, scenario=sc.name)


@pytest.fixture(scope="session")
def random_files(random_spec: ExportSpec) -> dict[str, str]:
    return package_files(random_spec)


@pytest.fixture(scope="session")
def library(random_files: dict[str, str], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The package's shared library, built as ``hitchpark sil`` builds it."""
    from hitchpark.app.sil import build_package

    compiler = compiler_or_skip()
    return build_package(random_files, tmp_path_factory.mktemp("sil") / "package", compiler)


@pytest.fixture(scope="module")
def compiled_in_process(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Compilation on for the in-process controller (its riccati_c) while the module runs, into one cache for the
    session's modules (compiled once, loaded by the next)."""
    compiler_or_skip()
    cache = tmp_path_factory.getbasetemp() / "compiled-in-process"
    cache.mkdir(exist_ok=True)
    saved = {k: os.environ.get(k) for k in ("HITCHPARK_JIT", "HITCHPARK_CACHE")}
    os.environ["HITCHPARK_JIT"], os.environ["HITCHPARK_CACHE"] = "1", str(cache)
    try:
        yield cache
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
