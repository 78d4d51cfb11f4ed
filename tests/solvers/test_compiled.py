"""The compiled solver: same answers as uncompiled, cached on disk, nothing left in the working folder."""

from __future__ import annotations

import numpy as np
import pytest

from hitchpark import VehicleTrailer
from hitchpark.control import NMPCSettings, make_nmpc
from hitchpark.model.plant import Measurement
from hitchpark.model.state import Pose, State
from hitchpark.solvers import compiled


def _plans(controller, starts):
    out = []
    for x, y, yaw, hitch in starts:
        controller.reset()
        m = Measurement(0.0, State(x, y, yaw, hitch), 0.0, 0.0)
        out.append(controller.act(m, Pose()))
    return out


@pytest.mark.slow
def test_compiled_matches_uncompiled_and_is_cached(jit_cache, monkeypatch):
    cache, work = jit_cache
    vehicle = VehicleTrailer()
    starts = [(8.0, 3.0, 0.5, 0.1), (12.0, -5.0, -1.0, -0.3), (5.0, 1.0, 0.2, 0.4)]
    compiled_ctl = make_nmpc(vehicle, NMPCSettings(solver="fatrop", jit=True))
    entries = list(cache.iterdir())
    assert len(entries) == 1 and (entries[0] / "solver.casadi").is_file()
    assert list(entries[0].glob("*.so")), "the shared library is kept beside the solver"
    assert not list(entries[0].glob("*.c")) and not list(entries[0].glob("*.o"))
    assert list(work.iterdir()) == [], "nothing written into the working folder"

    plain = make_nmpc(vehicle, NMPCSettings(solver="fatrop", jit=False))
    for a, b in zip(_plans(compiled_ctl, starts), _plans(plain, starts), strict=True):
        assert a.ok and b.ok
        assert a.front_steer == pytest.approx(b.front_steer, abs=1e-7)
        assert a.rear_speed == pytest.approx(b.rear_speed, abs=1e-7)
        np.testing.assert_allclose(a.predicted_states, b.predicted_states, atol=1e-6)

    # A second controller of the same problem loads the cache instead of compiling.
    built = []
    real_nlpsol = compiled.ca.nlpsol

    def spy(name, plugin, nlp, options):
        built.append(bool(options.get("jit")))
        return real_nlpsol(name, plugin, nlp, options)

    monkeypatch.setattr(compiled.ca, "nlpsol", spy)
    again = make_nmpc(vehicle, NMPCSettings(solver="fatrop", jit=True))
    assert True not in built, "compiled again although the cache holds this solver"
    assert again.solver is not compiled_ctl.solver
    assert _plans(again, starts[:1])[0].front_steer == pytest.approx(_plans(plain, starts[:1])[0].front_steer, abs=1e-7)


@pytest.mark.slow
def test_a_broken_cache_entry_is_rebuilt(jit_cache):
    cache, _ = jit_cache
    vehicle = VehicleTrailer()
    settings = NMPCSettings(kind="paper", solver="fatrop", jit=True)  # the smaller OCP: compiled twice here
    make_nmpc(vehicle, settings)
    (entry,) = cache.iterdir()
    (entry / "solver.casadi").write_text("cut short")
    rebuilt = make_nmpc(vehicle, settings)
    assert _plans(rebuilt, [(8.0, 3.0, 0.5, 0.1)])[0].ok
    assert (entry / "solver.casadi").stat().st_size > 1000


def test_switched_off_or_without_compiler_runs_uncompiled(tmp_path, monkeypatch):
    monkeypatch.setenv("HITCHPARK_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("HITCHPARK_JIT", "0")
    assert not compiled.jit_available()
    assert make_nmpc(VehicleTrailer(), NMPCSettings(solver="fatrop", jit=True)).solver is not None
    monkeypatch.setenv("HITCHPARK_JIT", "1")
    monkeypatch.setenv("CC", "no-such-compiler-hitchpark")
    assert not compiled.jit_available()
    assert _plans(make_nmpc(VehicleTrailer(), NMPCSettings(solver="fatrop", jit=True)), [(8.0, 3.0, 0.5, 0.1)])[0].ok
    assert not (tmp_path / "cache").exists()


def test_jit_setting_is_checked_and_resolved_per_kind():
    from hitchpark.checks import InputError

    assert NMPCSettings().jit is True
    assert NMPCSettings(kind="paper").jit is False
    with pytest.raises(InputError, match=r"nmpc\.jit"):
        NMPCSettings(jit="yes")  # type: ignore[arg-type]


def _build_and_plan(_: int) -> bool:
    # The paper's OCP, the smaller one (as in the broken entry's test): the cache's lock is the same whatever it holds.
    settings = NMPCSettings(kind="paper", solver="fatrop", jit=True)
    return bool(_plans(make_nmpc(VehicleTrailer(), settings), [(8.0, 3.0, 0.5, 0.1)])[0].ok)


@pytest.mark.slow
def test_a_pool_compiles_once(jit_cache):
    """Workers of a pool starting together: one compiles, the others wait and load (no half-built library). They
    build the paper's OCP, which compiles in about 1 s where the full one takes 7: the cache and its lock are the
    same for any."""
    import multiprocessing

    cache, _ = jit_cache
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        assert pool.map(_build_and_plan, range(2)) == [True, True]
    (entry,) = cache.iterdir()
    assert len(list(entry.glob("*.so"))) == 1
