"""Shared fixtures and the Hypothesis profile for the hitchpark tests."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from hitchpark.model import VehicleTrailer

# Compiling each controller's NLP to C takes seconds and the suite builds dozens of them: it runs
# uncompiled (same expressions, same results to rounding). Tests that compile ask for `jit_cache`.
os.environ.setdefault("HITCHPARK_JIT", "0")

# Modest example counts and no per-example deadline: the suite must stay fast and must
# not fail because a machine happens to be slow.
settings.register_profile(
    "hitchpark",
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
# CI replays the same examples on every run, so a result there never depends on luck;
# local runs keep exploring new examples.
settings.register_profile("ci", parent=settings.get_profile("hitchpark"), derandomize=True, database=None)
settings.load_profile("ci" if os.environ.get("CI") else "hitchpark")


@pytest.fixture
def table4() -> VehicleTrailer:
    """The paper's simulation vehicle (Table 4), which is also the package default."""
    return VehicleTrailer()


@pytest.fixture
def table2() -> VehicleTrailer:
    """The inverse-kinematics study vehicle (Table 2): L = 3, L_H = 1, L_T = 2.5 m."""
    return VehicleTrailer(wheelbase=3.0, hitch_offset=1.0, trailer_length=2.5)


def _compiling(cache: Path, work: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    from hitchpark.native import resolved_compiler

    if resolved_compiler() is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("HITCHPARK_JIT", "1")
    monkeypatch.setenv("HITCHPARK_CACHE", str(cache))
    work.mkdir()
    monkeypatch.chdir(work)
    return cache, work


@pytest.fixture
def jit_cache(tmp_path, monkeypatch):
    """Compilation on, into a cache of this test's own, from a working folder that must stay empty: for a test of
    the cache itself, or of what happens where nothing compiles."""
    return _compiling(tmp_path / "cache", tmp_path / "work", monkeypatch)


@pytest.fixture(scope="session")
def _run_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One cache for the run: shared by pytest-xdist's workers (their folders' parent is the run's), each library
    compiled by the first that asks and loaded by the others (``hitchpark.native`` builds under a lock)."""
    base = tmp_path_factory.getbasetemp()
    return (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "run-cache"


@pytest.fixture
def shared_jit_cache(_run_cache, tmp_path, monkeypatch):
    """Compilation on, into the run's one cache (a solver the suite compiles in several tests is compiled once),
    from a working folder of this test's own that must stay empty."""
    return _compiling(_run_cache, tmp_path / "work", monkeypatch)
