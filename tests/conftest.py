"""Shared fixtures and the Hypothesis profile for the hitchpark tests."""

from __future__ import annotations

import os

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


@pytest.fixture
def jit_cache(tmp_path, monkeypatch):
    """Compilation on, into a cache of this test's own, from a working folder that must stay empty."""
    from hitchpark.native import resolved_compiler

    if resolved_compiler() is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("HITCHPARK_JIT", "1")
    monkeypatch.setenv("HITCHPARK_CACHE", str(tmp_path / "cache"))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    return tmp_path / "cache", work
