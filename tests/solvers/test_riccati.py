"""hitchpark's own structured solver, ``riccati_c``: IPOPT's optimum and a KKT point with its multipliers, from a
cold and from a warm start; what it cannot take, refused as a failure; the options it takes."""

from __future__ import annotations

import math
import subprocess
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from hitchpark import VehicleTrailer
from hitchpark.checks import InputError
from hitchpark.control import NMPCSettings, TrailerNMPC, make_nmpc
from hitchpark.ocp.full import STEER
from hitchpark.solvers.generated import GeneratedNLP
from hitchpark.solvers.registry import make_solver, takes_free_initial
from hitchpark.solvers.riccati import checked_options


def _riccati(controller, floor=None):
    tr = controller.transcription
    floor = controller.settings.dual_floor if floor is None else floor
    return make_solver("riccati_c", tr.nlp, list(tr.lbg == tr.ubg), transcription=tr, dual_floor=floor)


def _kkt(tr):
    """The NLP's cost, constraints, cost gradient and constraint Jacobian, as one CasADi function of (x, p)."""
    nlp = tr.nlp
    x, p = nlp["x"], nlp["p"]
    return ca.Function("kkt", [x, p], [nlp["f"], nlp["g"], ca.gradient(nlp["f"], x), ca.jacobian(nlp["g"], x)])


def _assert_kkt_point(kkt, problem, answer, tol=1e-6):
    """``answer`` (x, f, g, lam_x, lam_g in CasADi's conventions) is a KKT point of ``problem``: feasible,
    stationary, each multiplier's sign that of its active bound, and f and g the NLP's own at x."""
    x, lam_x, lam_g = (np.asarray(answer[k], dtype=float).ravel() for k in ("x", "lam_x", "lam_g"))
    f, g, grad, jac = kkt(x, problem.p)
    g = np.asarray(g).ravel()
    assert answer["f"] == pytest.approx(float(f), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(answer["g"], g, atol=1e-12, rtol=1e-12)
    # Stationarity, scaled as the solver's test is (by the multipliers' size).
    scale = max(1.0, (np.abs(lam_x).sum() + np.abs(lam_g).sum()) / (len(lam_x) + len(lam_g)))
    residual = np.asarray(grad).ravel() + np.asarray(jac.T @ lam_g).ravel() + lam_x
    assert np.max(np.abs(residual)) <= 10 * tol * scale
    # Feasible, and complementary: a negative multiplier belongs to a lower bound, a positive one to an upper,
    # each times its distance from that bound no more than the barrier leaves (mu = 1e-9, tolerance 1e-8).
    for value, low, high, lam in ((g, problem.lbg, problem.ubg, lam_g), (x, problem.lbx, problem.ubx, lam_x)):
        assert np.all(value >= low - tol) and np.all(value <= high + tol)
        with np.errstate(invalid="ignore"):  # inf * 0 where a bound is infinite and its multiplier 0
            below = np.where(lam < 0.0, -lam * (value - low), 0.0)
            above = np.where(lam > 0.0, lam * (high - value), 0.0)
        assert np.max(below, initial=0.0) <= 1e-7 and np.max(above, initial=0.0) <= 1e-7


@pytest.mark.slow
@pytest.mark.parametrize("ocp", ["paper", "full", "obstacles"])
def test_riccati_reaches_ipopts_optimum_from_cold_and_warm_starts(shared_jit_cache, request, ocp, ipopt_answers):
    controller, problems = request.getfixturevalue(f"{'obstacle' if ocp == 'obstacles' else ocp}_problems")
    tr = controller.transcription
    solver = _riccati(controller)
    assert isinstance(solver, GeneratedNLP) and solver.warm_duals
    references = ipopt_answers(ocp, controller, problems)  # IPOPT's answers, solved once for every route's test
    kkt = _kkt(tr)
    assert len(problems) >= 10
    previous = None
    for problem, (_, x_ref, f_ref) in zip(problems, references, strict=True):
        first_ref = tr.unpack(x_ref, problem.p)[1][0]
        # Cold, then from the multipliers of the problem before (the suite records none: fatrop in-process).
        starts = [{}] if previous is None else [{}, {"lam_x0": previous["lam_x"], "lam_g0": previous["lam_g"]}]
        for start in starts:
            answer = solver(**problem.inputs(), **start)
            assert solver.stats()["success"], f"riccati_c failed on a recorded {ocp} problem ({sorted(start)})"
            assert answer["f"] == pytest.approx(f_ref, rel=1e-5, abs=1e-9)
            first = tr.unpack(np.asarray(answer["x"]).ravel(), problem.p)[1][0]  # the move the car is given
            np.testing.assert_allclose(first, first_ref, atol=2e-4)
            _assert_kkt_point(kkt, problem, answer)
        previous = answer


@pytest.mark.slow
@pytest.mark.parametrize("ocp", ["paper", "full", "obstacles"])
def test_riccati_corrector_takes_fewer_iterations_to_the_same_optimum(shared_jit_cache, request, ocp):
    """Mehrotra's corrector (the default) against the plain Newton step, warm-started along the recorded loop."""
    controller, problems = request.getfixturevalue(f"{'obstacle' if ocp == 'obstacles' else ocp}_problems")
    tr = controller.transcription
    iterations, answers = {}, {}
    for corrector in (True, False):
        solver = make_solver(
            "riccati_c",
            tr.nlp,
            list(tr.lbg == tr.ubg),
            {"corrector": corrector},
            transcription=tr,
            dual_floor=controller.settings.dual_floor,
        )
        previous, iterations[corrector], answers[corrector] = None, [], []
        for problem in problems:
            start = {} if previous is None else {"lam_x0": previous["lam_x"], "lam_g0": previous["lam_g"]}
            previous = solver(**problem.inputs(), **start)
            assert solver.stats()["success"], f"riccati_c (corrector {corrector}) failed on a recorded {ocp} problem"
            iterations[corrector].append(solver.stats()["iter_count"])
            answers[corrector].append(np.asarray(previous["x"]).ravel())
    for mine, plain in zip(answers[True], answers[False], strict=True):
        np.testing.assert_allclose(mine, plain, atol=1e-4)
    assert sum(iterations[True]) < sum(iterations[False]), iterations


@pytest.mark.slow
def test_riccati_frees_a_component_of_x0_as_ipopt_does(shared_jit_cache, obstacle_problems):
    """The free-steer problem among obstacles (X_0's steer freed from the measured one, within the car's
    steer limit; its row's bounds infinite): riccati_c takes it, from a cold start as the controller gives
    it, and reaches IPOPT's optimum, a KKT point whose freed row has no multiplier."""
    controller, problems = obstacle_problems
    tr = controller.transcription
    solver = _riccati(controller)
    ipopt = make_solver("ipopt", tr.nlp, list(tr.lbg == tr.ubg))
    kkt = _kkt(tr)
    limit = controller.vehicle.max_steer
    moved = 0
    for problem in problems[::4]:
        lbx, ubx, lbg, ubg = (a.copy() for a in (problem.lbx, problem.ubx, problem.lbg, problem.ubg))
        lbx[STEER], ubx[STEER] = -limit, limit
        lbg[STEER], ubg[STEER] = -math.inf, math.inf
        freed = replace(problem, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        reference = ipopt(**freed.inputs())
        answer = solver(**freed.inputs())
        assert solver.stats()["success"] and ipopt.stats()["success"]
        assert answer["f"] == pytest.approx(float(reference["f"]), rel=1e-5, abs=1e-9)
        steer = float(answer["x"][STEER])
        assert steer == pytest.approx(float(reference["x"][STEER]), abs=1e-5)
        assert answer["lam_g"][STEER] == 0.0
        _assert_kkt_point(kkt, freed, answer)
        moved += abs(steer - problem.p[STEER]) > 1e-3
    assert moved  # the wheels' angle chosen, not the measured one kept


@pytest.mark.slow
def test_riccati_from_its_own_answer_is_done_at_once(shared_jit_cache, obstacle_problems, monkeypatch):
    controller, problems = obstacle_problems
    solver = _riccati(controller, floor=1e-12)
    steps = []
    for problem in problems:
        answer = solver(**problem.inputs())
        cold = solver.stats()["iter_count"]
        again = solver(**{**problem.inputs(), "x0": answer["x"], "lam_x0": answer["lam_x"], "lam_g0": answer["lam_g"]})
        steps.append((cold, solver.stats()["iter_count"]))
        assert solver.stats()["success"]
        np.testing.assert_allclose(again["x"], answer["x"], atol=1e-6)
    assert all(again <= 1 for _, again in steps), steps
    assert sum(cold for cold, _ in steps) > len(steps)  # the problems themselves take iterations

    # A second solver of the same problem loads the library instead of compiling it.
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("compiled again despite the cache"))
    assert isinstance(_riccati(controller), GeneratedNLP)


@pytest.mark.slow
def test_riccati_fails_on_what_it_cannot_take(shared_jit_cache, obstacle_problems):
    controller, problems = obstacle_problems
    solver = _riccati(controller)
    iterations = []
    for candidate in problems:
        solver(**candidate.inputs())
        assert solver.stats()["success"]
        iterations.append(solver.stats()["iter_count"])
    problem = problems[int(np.argmax(iterations))]  # one that takes more than one iteration
    assert max(iterations) > 1
    # An X_0 = x0 row relaxed but not freed (the free-steer problem frees its row whole, which it takes),
    # or freed on one side only: refused.
    for low, high in ((-0.1, 0.0), (-math.inf, 0.0), (0.0, math.inf)):
        lbg, ubg = problem.lbg.copy(), problem.ubg.copy()
        lbg[4], ubg[4] = low, high
        solver(**{**problem.inputs(), "lbg": lbg, "ubg": ubg})
        assert solver.stats() == {"success": False, "return_status": "not converged (code 4)", "iter_count": 0}
    lbg, ubg = problem.lbg.copy(), problem.ubg.copy()
    lbg[4], ubg[4] = -math.inf, math.inf  # X_0's steer free, within no bound: the problem is still solved
    solver(**{**problem.inputs(), "lbg": lbg, "ubg": ubg})
    assert solver.stats()["success"]
    # A start it cannot evaluate: refused before any step.
    x0 = problem.w0.copy()
    x0[9] = math.nan
    solver(**{**problem.inputs(), "x0": x0})
    assert solver.stats()["return_status"] == "not converged (code 3)"
    # Multipliers with a NaN are not used: the solve is the cold one, to the last bit.
    cold = solver(**problem.inputs())
    cold_stats = solver.stats()
    answer = solver(**problem.inputs())
    lam_g = answer["lam_g"].copy()
    lam_g[len(lam_g) // 2] = math.nan
    ignored = solver(**problem.inputs(), lam_x0=answer["lam_x"], lam_g0=lam_g)
    assert solver.stats() == cold_stats
    np.testing.assert_array_equal(ignored["x"], cold["x"])
    # Out of iterations: a failure, whatever the iterate.
    tr = controller.transcription
    short = make_solver("riccati_c", tr.nlp, list(tr.lbg == tr.ubg), {"max_iter": 1}, transcription=tr)
    short(**problem.inputs())
    assert short.stats() == {"success": False, "return_status": "not converged (code 1)", "iter_count": 1}


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"max_itr": 5},
            "unknown option 'max_itr'; the options are tol, mu, max_iter, bound_push, corrector, warm_iterations, "
            "whole_steps_only",
        ),
        ({"whole_steps_only": 1, "warm_iterations": 1}, "option 'whole_steps_only' must be True or False, got 1"),
        (
            {"whole_steps_only": True},
            "option 'whole_steps_only' needs 'warm_iterations' (the Newton steps before the cap)",
        ),
        ({"warm_iterations": 0}, "option 'warm_iterations' must be None or a whole number in [1, max_iter], got 0"),
        (
            {"warm_iterations": True},
            "option 'warm_iterations' must be None or a whole number in [1, max_iter], got True",
        ),
        ({"corrector": 1}, "option 'corrector' must be True or False, got 1"),
        ({"mu": 1e-8}, "option 'mu' must be below 'tol' (1e-08), got 1e-08"),
        ({"tol": "small"}, "option 'tol' must be a number in (0, 1), got 'small'"),
        ({"max_iter": 2.5}, "option 'max_iter' must be a whole number of at least 1, got 2.5"),
    ],
)
def test_riccati_refuses_options_it_does_not_take(options, message):
    with pytest.raises(InputError) as caught:
        make_nmpc(VehicleTrailer(), NMPCSettings(kind="paper", solver="riccati_c", solver_options=options))
    assert str(caught.value) == f"nmpc.solver_options are not accepted by riccati_c: {message}"


@pytest.mark.slow
def test_riccati_warm_iterations_caps_a_warm_solve_only(shared_jit_cache, full_problems):
    """``warm_iterations`` (opt-in): a warm-started solve stops after that many Newton steps and answers its iterate
    as a success, its cost and constraints the NLP's own at that iterate, within its bounds; a cold solve is the
    default's, to the bit. Off by default: no HP_WARM_ITER in the solver's C."""
    from hitchpark.solvers.riccati import _config, riccati_functions

    controller, problems = full_problems
    tr = controller.transcription
    assert "HP_WARM_ITER" not in _config(tr, riccati_functions(tr, "x_"), checked_options(None))
    equality = list(tr.lbg == tr.ubg)
    full = _riccati(controller)
    kkt = _kkt(tr)
    for cap in (1, 2):
        capped = make_solver("riccati_c", tr.nlp, equality, {"warm_iterations": cap}, transcription=tr,
                             dual_floor=controller.settings.dual_floor)  # fmt: skip
        previous, reached = None, 0
        for problem in problems:
            if previous is None:  # cold: the default's solve, to the bit
                cold = capped(**problem.inputs())
                np.testing.assert_array_equal(cold["x"], full(**problem.inputs())["x"])
                assert capped.stats()["iter_count"] == full.stats()["iter_count"] > cap
                previous = cold
                continue
            # Warm, from the multipliers of the problem before (the suite records none: fatrop in-process).
            start = {"lam_x0": previous["lam_x"], "lam_g0": previous["lam_g"]}
            answer = capped(**problem.inputs(), **start)
            stats = capped.stats()
            assert stats["success"] and stats["iter_count"] <= cap
            reached += stats["iter_count"] == cap
            x = np.asarray(answer["x"]).ravel()
            f, g = kkt(x, problem.p)[:2]
            assert answer["f"] == pytest.approx(float(f), rel=1e-12, abs=1e-12)
            np.testing.assert_allclose(answer["g"], np.asarray(g).ravel(), atol=1e-12, rtol=1e-12)
            assert np.all(x >= problem.lbx) and np.all(x <= problem.ubx)
            previous = full(**problem.inputs(), **start)
            if full.stats()["iter_count"] < cap:  # converged before the cap: the same answer
                np.testing.assert_array_equal(x, np.asarray(previous["x"]).ravel())
        assert reached > 0


@pytest.mark.slow
@pytest.mark.parametrize("recorded", ["full_problems", "obstacle_problems"])
def test_riccati_whole_steps_only_answers_a_step_taken_whole(shared_jit_cache, recorded, request):
    """``whole_steps_only`` with ``warm_iterations = 1``: a warm solve runs the default's iterations and stops at the
    first step taken whole. So it never takes more steps than the default; where it takes as many, it answers the
    default's answer to the bit, and where it takes one, the plain cap's. On the recorded problems (the full OCP's
    and the obstacle OCP's at the campsite, each warm-started from the answer to the problem before) it answers
    after one step somewhere the default takes more, and goes on past a step cut short somewhere else."""
    controller, problems = request.getfixturevalue(recorded)
    tr = controller.transcription
    equality = list(tr.lbg == tr.ubg)
    floor = controller.settings.dual_floor
    full = _riccati(controller)
    plain = make_solver("riccati_c", tr.nlp, equality, {"warm_iterations": 1}, transcription=tr, dual_floor=floor)
    whole = make_solver("riccati_c", tr.nlp, equality, {"warm_iterations": 1, "whole_steps_only": True},
                        transcription=tr, dual_floor=floor)  # fmt: skip
    kkt = _kkt(tr)
    previous, one_step, went_on = None, 0, 0
    for problem in problems:
        if previous is not None:
            start = {"lam_x0": previous["lam_x"], "lam_g0": previous["lam_g"]}
            answer = whole(**problem.inputs(), **start)
            stats = whole.stats()
            assert stats["success"]
            x = np.asarray(answer["x"]).ravel()
            f, g = kkt(x, problem.p)[:2]
            assert answer["f"] == pytest.approx(float(f), rel=1e-12, abs=1e-12)
            np.testing.assert_allclose(answer["g"], np.asarray(g).ravel(), atol=1e-12, rtol=1e-12)
            reference = full(**problem.inputs(), **start)
            steps, default_steps = stats["iter_count"], full.stats()["iter_count"]
            assert 1 <= steps <= default_steps
            if steps == default_steps:
                np.testing.assert_array_equal(x, np.asarray(reference["x"]).ravel())
            if steps == 1:
                np.testing.assert_array_equal(x, np.asarray(plain(**problem.inputs(), **start)["x"]).ravel())
            one_step += steps == 1 < default_steps
            went_on += steps > 1
            previous = reference
        else:
            previous = full(**problem.inputs())
    assert one_step > 0 and went_on > 0


def test_riccati_stands_in_fatrop_where_nothing_compiles(tmp_path, monkeypatch):
    monkeypatch.setenv("HITCHPARK_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("HITCHPARK_JIT", "0")
    nmpc = TrailerNMPC(VehicleTrailer(), NMPCSettings(kind="paper", solver="riccati_c"))
    assert not isinstance(nmpc.solver, GeneratedNLP)
    assert not takes_free_initial(nmpc.solver)  # a free-steer problem then goes to the relaxed route
    assert nmpc.step(10.0, 3.5, 0.0, 0.0).ok
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("horizon", [1, 2, 7])
def test_riccati_steps_as_ipopt_at_any_horizon(shared_jit_cache, horizon):
    steps = {}
    for solver in ("riccati_c", "ipopt"):
        nmpc = TrailerNMPC(VehicleTrailer(), NMPCSettings(kind="paper", horizon=horizon, solver=solver))
        assert isinstance(nmpc.solver, GeneratedNLP) == (solver == "riccati_c")
        steps[solver] = [nmpc.step(10.0, 3.5, 0.2, math.radians(10.0)), nmpc.step(9.9, 3.45, 0.21, math.radians(9.0))]
    for mine, reference in zip(steps["riccati_c"], steps["ipopt"], strict=True):
        assert mine.ok and reference.ok
        assert mine.virtual_steer == pytest.approx(reference.virtual_steer, abs=1e-5)
        assert mine.trailer_speed == pytest.approx(reference.trailer_speed, abs=1e-5)


@pytest.mark.slow
def test_riccati_from_a_cold_start_at_a_long_horizon(shared_jit_cache):
    """A closed loop's first problem, with no multipliers to start from, at N = 80 (the full OCP): the barrier
    parameter comes down from IPOPT's start rather than beginning at its last value (which stalled here)."""
    from hitchpark.app.bench import BENCH_OCPS, own_problems
    from hitchpark.maneuver import park

    class First(list):
        """A recorder that ends the closed loop at its first problem: the first of ``record_problems``' recording
        of the whole loop (the same controller and park, to the bit), without the rest of the loop, which is never
        used (all of its problems are of this OCP)."""

        def append(self, problem):
            super().append(problem)
            raise Recorded

    class Recorded(Exception):
        pass

    ocp, vehicle = BENCH_OCPS["full"], VehicleTrailer()
    (start,) = ocp.starts(1)
    settings = ocp.settings(80)  # as record_problems(ocp, vehicle, ocp.starts(1), horizon=80) records
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("HITCHPARK_JIT", "0")  # recorded as the suite's other problems are
        controller = make_nmpc(vehicle, settings.nmpc)
        controller.recorder = First()
        with pytest.raises(Recorded):
            park(vehicle, start.start, start.goal, settings, name=start.name, controller=controller, plant=ocp.plant,
                 scene=start.scene)  # fmt: skip
    (first,) = own_problems(controller, controller.recorder)
    tr = controller.transcription
    solver, ipopt = _riccati(controller), make_solver("ipopt", tr.nlp, list(tr.lbg == tr.ubg))
    reference = ipopt(**first.inputs())
    answer = solver(**first.inputs())
    assert solver.stats()["success"] and ipopt.stats()["success"]
    assert answer["f"] == pytest.approx(float(reference["f"]), rel=1e-6)
    np.testing.assert_allclose(np.asarray(answer["x"]).ravel(), np.asarray(reference["x"]).ravel(), atol=1e-4)
    _assert_kkt_point(_kkt(tr), first, answer)
