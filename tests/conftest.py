"""Shared fixtures and the Hypothesis profile for the hitchpark tests."""

from __future__ import annotations

import fcntl
import hashlib
import os
import pickle
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import casadi as ca
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


@pytest.fixture(scope="session")
def once_a_run(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str, Callable[[], Any]], Any]:
    """``once_a_run(name, compute)``: what ``compute()`` returns, computed once for the whole run. Under
    pytest-xdist the first worker that asks computes it and saves its pickle in the run's temporary root; the
    others wait on a lock (fcntl) meanwhile and load it (as the export tests' build, ``tests/export/conftest.py``).
    The caller that computed it gets the value itself, every other call a copy of its own, the same to the bit."""
    base = tmp_path_factory.getbasetemp()
    home = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "once-a-run"
    home.mkdir(exist_ok=True)

    def once(name: str, compute: Callable[[], Any]) -> Any:
        with open(home / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            saved = home / f"{name}.pickle"
            if saved.is_file():
                return pickle.loads(saved.read_bytes())
            value = compute()
            partial = home / f"{name}.partial"
            partial.write_bytes(pickle.dumps(value))
            partial.replace(saved)
            return value

    return once


@contextmanager
def uncompiled() -> Iterator[None]:
    """Compilation off while the block runs, whatever the test that asks set (one with ``jit_cache`` compiles)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("HITCHPARK_JIT", "0")
        yield


def _posed_in(controller: Any) -> str:
    """A digest of the OCP the controller poses its solver now: its transcription's NLP, as its compile key has it."""
    nlp = controller.transcription.nlp
    graph = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]).serialize()
    return hashlib.sha256(graph.encode()).hexdigest()


def _posing(vehicle: Any, settings: Any, scene: Any, digest: str) -> Any:
    """A fresh controller of ``settings`` that poses the OCP of ``digest``, or None: the full NMPC keeps clear of the
    scene as the maneuver's process has it and then tracks a path or parks (:meth:`FullNMPC._program_for`)."""
    from hitchpark.control import make_nmpc
    from hitchpark.control.nmpc import FullNMPC
    from hitchpark.maneuver.process import predicted_clearance_m
    from hitchpark.model.scene import Scene

    with uncompiled():
        controller = make_nmpc(vehicle, settings.nmpc)
        if not isinstance(controller, FullNMPC):
            return controller if _posed_in(controller) == digest else None
        planned = settings.process.resolved(settings.nmpc.kind) == "planned"
        controller.keep_clear(scene if planned else Scene(), predicted_clearance_m(settings))
        for tracking in (False, True):
            controller._program = controller._program_for(tracking)
            if _posed_in(controller) == digest:
                return controller
    return None


@pytest.fixture(scope="session")
def recorded_park(once_a_run):
    """``recorded_park(name, vehicle, start, goal, settings, plant, scene)``: ``(controller, result, problems)``, the
    maneuver ``park`` gives from ``start`` (uncompiled, the suite's setting) and every problem its NMPC posed its
    primary solver (``controller.recorder``, which changes nothing in the maneuver), parked once a run
    (:func:`once_a_run`) for the solver tests' recorded problems and the maneuver tests alike. ``controller`` poses
    the OCP of the problems: the one that parked, or where another worker parked, a fresh one of the same settings
    that poses the same OCP to the bit (its NLP's digest); if none does, the maneuver is parked here again."""
    from hitchpark.control import make_nmpc
    from hitchpark.maneuver import park
    from hitchpark.model.scene import Scene

    def record(name: str, vehicle: Any, start: Any, goal: Any, settings: Any, plant: Any = None, scene: Any = None):
        scene = scene if scene is not None else Scene()
        made: dict[str, Any] = {}

        def compute() -> tuple[Any, list, str]:
            with uncompiled():
                controller = make_nmpc(vehicle, settings.nmpc)
                controller.recorder = problems = []
                result = park(vehicle, start, goal, settings, controller=controller, plant=plant, scene=scene)
                controller.recorder = None
            made["controller"] = controller
            return result, problems, _posed_in(controller)

        result, problems, digest = once_a_run(f"recorded-{name}", compute)
        controller = made["controller"] if made else _posing(vehicle, settings, scene, digest)
        if controller is None:
            result, problems, _ = compute()
            controller = made["controller"]
        return controller, result, problems

    return record


@pytest.fixture(scope="session")
def campsite_recorded(recorded_park):
    """The campsite scene parked with its scenario's settings (the full model keeping clear of the scene, uncompiled),
    and every problem of its NMPC (the obstacle OCP): ``tests/maneuver/test_planned.py`` asserts on the maneuver, the
    solver tests solve the problems."""
    from hitchpark.maneuver.scenario import builtin_scenario

    sc = builtin_scenario("campsite")
    return recorded_park("campsite", sc.vehicle, sc.start, sc.goal, sc.settings, sc.plant, sc.scene)
