"""Solver routes: every route reaches the same optimum on recorded closed-loop problems; generated C is
the same solver, cached, and reports its failures."""

from __future__ import annotations

import ctypes
import math
import re
import subprocess
from dataclasses import replace

import numpy as np
import pytest

from hitchpark import VehicleTrailer
from hitchpark.control import NMPCSettings, TrailerNMPC, make_nmpc
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.solvers.generated import GeneratedNLP
from hitchpark.solvers.registry import ROUTES, make_solver


def _problems(ocp, paper_problems, full_problems, obstacle_problems):
    return {"paper": paper_problems, "full": full_problems, "obstacles": obstacle_problems}[ocp]


def _solve_all(solver, problems):
    out = []
    for problem in problems:
        answer = solver(**problem.inputs())
        out.append((solver.stats()["success"], np.asarray(answer["x"]).ravel(), float(answer["f"])))
    return out


# BFGS (no second derivatives) takes seconds per obstacle problem, with their hundreds of inequalities, and
# runs out of iterations on some: ``hitchpark bench`` measures it there; the suite leaves it out.
@pytest.mark.slow
@pytest.mark.parametrize(
    ("route", "ocp"),
    [(r, o) for o in ("paper", "full", "obstacles") for r in sorted(ROUTES) if (r, o) != ("sqp_bfgs", "obstacles")],
)
def test_every_route_reaches_the_reference_optimum(
    route, ocp, paper_problems, full_problems, obstacle_problems, ipopt_answers
):
    controller, problems = _problems(ocp, paper_problems, full_problems, obstacle_problems)
    assert len(problems) >= 10
    reference = ipopt_answers(ocp, controller, problems)  # IPOPT's answers, solved once for every route
    if route == "sqp_bfgs":  # tens of milliseconds a problem: ten of them say as much
        problems, reference = problems[:10], reference[:10]
    tr = controller.transcription
    equality = list(tr.lbg == tr.ubg)
    got = _solve_all(make_solver(route, tr.nlp, equality), problems)
    for problem, (ok, w, f), (ok_ref, w_ref, f_ref) in zip(problems, got, reference, strict=True):
        assert ok and ok_ref, f"{route} failed on a recorded {ocp} problem"
        # Within the routes' tolerances (fatrop and sqp stop at 1e-8, IPOPT at 1e-9; the optimum is flat in
        # some directions near a stop): the same optimum.
        assert f == pytest.approx(f_ref, rel=1e-5, abs=1e-9)
        first = tr.unpack(w, problem.p)[1][0]  # the move the car is given
        np.testing.assert_allclose(first, tr.unpack(w_ref, problem.p)[1][0], atol=2e-4)


def _free_steer(fallback: str | None, relaxed: str | None) -> tuple[float | None, object]:
    from hitchpark.model.plant import Measurement
    from hitchpark.model.state import Pose, State

    settings = NMPCSettings(solver="fatrop_c", fallback_solver=fallback, relaxed_solver=relaxed)
    controller = make_nmpc(VehicleTrailer(), settings)
    m = Measurement(0.0, State(6.0, 1.0, 0.3, 0.1), 0.0, 0.0)
    steer = controller.initial_steer(m, Pose())
    program = controller._program
    general = program.relaxed if program.relaxed is not None else program.general
    assert general is not None and general is not controller.solver
    return steer, general


@pytest.mark.parametrize(
    ("fallback", "relaxed"), [(None, "sqp_c"), ("fatrop", "sqp_c"), ("fatrop", None), (None, "sqp")]
)
def test_a_structured_route_hands_the_free_steer_problem_to_a_general_one(fallback, relaxed):
    """The free-steer problem of a stage start relaxes X_0[steer] = p[steer]: fatrop cannot take that, so it
    goes to ``relaxed_solver`` (else a general fallback, else IPOPT), even with no fallback, and finds
    IPOPT's steer."""
    reference, ipopt = _free_steer(None, None)  # neither named: IPOPT
    assert ipopt.name().endswith("ipopt")
    assert reference is not None and abs(reference) <= VehicleTrailer().max_steer
    assert abs(reference) > 1e-3  # a start off the axis asks for the wheels turned
    steer, general = _free_steer(fallback, relaxed)
    assert general.name().endswith(relaxed or "ipopt")  # a structured fallback cannot take it either
    assert steer == pytest.approx(reference, abs=1e-6)


def test_a_relaxed_route_that_is_the_fallback_is_the_fallback_solver_itself():
    """Named twice, IPOPT is built once: on a failure the cascade does not solve the same problem again."""
    settings = NMPCSettings(solver="fatrop_c", fallback_solver="ipopt", relaxed_solver="ipopt")
    controller = make_nmpc(VehicleTrailer(), settings)
    assert controller._relaxed_solver() is controller._program.fallback is not None


@pytest.mark.slow
def test_riccati_takes_the_free_steer_problem_itself(shared_jit_cache):
    """``riccati_c`` frees X_0[steer] itself (hitchpark's own solver takes a free component of X_0): no
    general route is built, and the steer is IPOPT's."""
    from hitchpark.model.plant import Measurement
    from hitchpark.model.state import Pose, State

    with pytest.MonkeyPatch.context() as patch:
        # fatrop_c: IPOPT answers (uncompiled whatever HITCHPARK_JIT says, from the cold guess: in open space no
        # solver plans before it), so the same steer whether fatrop_c is compiled or not: not, 4 s sooner.
        patch.setenv("HITCHPARK_JIT", "0")
        reference, _ = _free_steer(None, None)
    controller = make_nmpc(VehicleTrailer(), NMPCSettings(solver="riccati_c", relaxed_solver="sqp_c"))
    assert isinstance(controller.solver, GeneratedNLP) and controller._relaxed_solver() is controller.solver
    steer = controller.initial_steer(Measurement(0.0, State(6.0, 1.0, 0.3, 0.1), 0.0, 0.0), Pose())
    assert steer == pytest.approx(reference, abs=1e-6)
    assert controller._program.relaxed is None and controller._program.general is None


@pytest.mark.slow
@pytest.mark.parametrize("name", ["driveway", "bay"])
def test_among_obstacles_the_relaxed_route_finds_ipopts_free_steer(name):
    """A scene's stage start: the free-steer problem among the scene's lines (and the plan of open space its
    cold start solves first) goes to ``relaxed_solver`` behind fatrop, with IPOPT's steer (riccati_c takes it
    itself: ``tests/control/test_riccati.py``)."""
    from hitchpark.model.plant import Measurement

    sc = builtin_scenario(name)
    steers = {}
    for relaxed in ("sqp_c", None):
        controller = make_nmpc(sc.vehicle, replace(sc.settings.nmpc, solver="fatrop_c", relaxed_solver=relaxed))
        controller.keep_clear(sc.scene, 0.3)
        m = Measurement(0.0, sc.start, 0.0, 0.0)
        steers[relaxed] = controller.initial_steer(m, sc.goal)
    assert steers[None] is not None and abs(steers[None]) > 1e-3
    assert steers["sqp_c"] == pytest.approx(steers[None], abs=1e-6)


@pytest.mark.slow
def test_generated_c_is_the_same_solver_cached_and_leaves_nothing_behind(jit_cache, paper_problems, monkeypatch):
    cache, work = jit_cache
    controller, problems = paper_problems
    tr = controller.transcription
    equality = list(tr.lbg == tr.ubg)
    generated = make_solver("fatrop_c", tr.nlp, equality, transcription=tr)
    assert isinstance(generated, GeneratedNLP)
    (entry,) = cache.iterdir()
    # The NLP's functions stage by stage are linked in (solvers/stagewise.py): their symbols are there.
    (library,) = entry.glob("*.so")
    assert hasattr(ctypes.CDLL(str(library)), "hitchpark_fatrop_c_stage_hess_l")
    assert [p.suffix for p in entry.iterdir() if not p.name.startswith(".")] == [".so"]
    assert list(work.iterdir()) == [], "nothing written into the working folder"
    in_process = make_solver("fatrop", tr.nlp, equality)
    for (ok, w, f), (ok_ref, w_ref, f_ref) in zip(
        _solve_all(generated, problems), _solve_all(in_process, problems), strict=True
    ):
        assert ok and ok_ref
        assert f == pytest.approx(f_ref, rel=1e-9, abs=1e-12)
        np.testing.assert_allclose(w, w_ref, atol=1e-8)

    # A second solver of the same problem loads the library instead of compiling it.
    def refuse(*args, **kwargs):
        raise AssertionError("compiled again although the cache holds this solver")

    monkeypatch.setattr(subprocess, "run", refuse)
    again = make_solver("fatrop_c", tr.nlp, equality, transcription=tr)
    assert isinstance(again, GeneratedNLP) and again is not generated
    assert _solve_all(again, problems[:1])[0][2] == pytest.approx(_solve_all(in_process, problems[:1])[0][2])


@pytest.mark.slow
def test_generated_c_reports_a_failure_and_the_controller_stops(shared_jit_cache):
    nmpc = TrailerNMPC(
        VehicleTrailer(),
        NMPCSettings(kind="paper", solver="fatrop_c", fallback_solver=None, solver_options={"fatrop.max_iter": 1}),
    )
    assert isinstance(nmpc.solver, GeneratedNLP)
    u = nmpc.step(10.0, 3.5, 0.0, math.radians(10.0))
    assert nmpc.solver.stats()["success"] is False
    assert u.ok is False and u.stop is True and "not converged" in u.status
    assert u.rear_speed == 0.0 and math.isfinite(u.front_steer)


@pytest.mark.slow
def test_generated_c_falls_back_to_the_fallback_solver(shared_jit_cache):
    nmpc = TrailerNMPC(
        VehicleTrailer(),
        NMPCSettings(kind="paper", solver="fatrop_c", fallback_solver="ipopt", solver_options={"fatrop.max_iter": 1}),
    )
    u = nmpc.step(10.0, 3.5, 0.0, 0.0)
    assert nmpc.solver.stats()["success"] is False
    assert u.ok and not u.stop and u.trailer_speed < 0.0


def _stalling_nlp():
    """x0 + x1 >= 3 and x0 x1 = p near (1, 2): from (0, 0) the product's linearization is zero, and an SQP
    step there goes nowhere (CasADi's sqpmethod: Search_Direction_Becomes_Too_Small)."""
    import casadi as ca

    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    nlp = {"x": x, "p": p, "f": (x[0] - 1) ** 2 + (x[1] - 2) ** 2, "g": ca.vertcat(x[0] + x[1], x[0] * x[1] - p)}
    return nlp, [False, True]


def test_generated_sqp_reports_a_solve_that_did_not_converge_as_casadis_sqp_does(shared_jit_cache):
    """CasADi 3.8's generated sqpmethod returned success however its iterations ended; the free-steer
    problem of a full NMPC at N = 80 came back so with its steer at 114 rad, and the stage started at full
    lock (issue 10's notes). Now it says what the in-process solver says."""
    nlp, equality = _stalling_nlp()
    generated, in_process = make_solver("sqp_c", nlp, equality), make_solver("sqp", nlp, equality)
    assert isinstance(generated, GeneratedNLP)
    for lbg, ubg, converges in (([3.0, -np.inf], [np.inf, -5.0], True), ([3.0, 0.0], [np.inf, 0.0], False)):
        answers = [solver(x0=[0.0, 0.0], p=0.0, lbg=lbg, ubg=ubg) for solver in (generated, in_process)]
        assert generated.stats()["success"] is in_process.stats()["success"] is converges
        np.testing.assert_allclose(*(np.asarray(a["x"], dtype=float).ravel() for a in answers), atol=1e-9)
    assert generated.stats()["return_status"] == "not converged (code 1)"


def test_generated_sqp_out_of_iterations_fails_and_the_fallback_answers(shared_jit_cache):
    settings = NMPCSettings(kind="paper", solver="sqp_c", fallback_solver=None, solver_options={"max_iter": 1})
    nmpc = TrailerNMPC(VehicleTrailer(), settings)
    assert isinstance(nmpc.solver, GeneratedNLP)
    u = nmpc.step(10.0, 3.5, 0.0, math.radians(10.0))
    assert nmpc.solver.stats()["success"] is False
    assert u.ok is False and u.stop is True and u.rear_speed == 0.0
    nmpc = TrailerNMPC(VehicleTrailer(), replace(settings, fallback_solver="ipopt"))
    u = nmpc.step(10.0, 3.5, 0.0, 0.0)
    assert u.ok and not u.stop and u.trailer_speed < 0.0


def test_a_generated_sqp_laid_out_otherwise_is_not_built(jit_cache, tmp_path, monkeypatch):
    """The edit changes the solver's last return alone; where the generated code has no single convergence
    test (another CasADi) it refuses, and no library is built: the in-process sqpmethod, which reports its
    status, serves instead."""
    import casadi as ca

    from hitchpark.solvers import casadi_patches
    from hitchpark.solvers.casadi_patches import report_sqp_failure

    nlp, equality = _stalling_nlp()
    plugin, options = ROUTES["sqp_c"].factory(equality)
    monkeypatch.chdir(tmp_path)  # CasADi writes into the working folder
    ca.nlpsol("s", plugin, nlp, {**options, "error_on_fail": True}).generate("s.c", {"main": False})
    source = (tmp_path / "s.c").read_text()
    reported = "return pr_inf < 1e-08 && du_inf < 1e-08 ? 0 : 1;"
    edited = report_sqp_failure(source)
    assert reported not in source and edited.count(reported) == 1
    assert edited.replace(reported, "return 0;") == source
    with pytest.raises(RuntimeError, match="convergence test"):
        report_sqp_failure(source.replace("du_inf < ", "du_inf <= "))
    with pytest.raises(RuntimeError, match="does not end"):
        report_sqp_failure(source.replace("\n  return 0;\n}\n", "\n  return 0; }\n"))
    # A CasADi whose generated code has no such test: the route is CasADi's in-process sqpmethod, and it fails
    # where it stalls.
    monkeypatch.setattr(casadi_patches, "_SQP_CONVERGED", re.compile("no such line"))
    solver = make_solver("sqp_c", nlp, equality)
    assert not isinstance(solver, GeneratedNLP)
    solver(x0=[0.0, 0.0], p=0.0, lbg=[3.0, 0.0], ubg=[np.inf, 0.0])
    assert solver.stats()["success"] is False


def test_the_edits_of_generated_code_give_up_on_a_casadi_they_were_not_tested_on(tmp_path, monkeypatch):
    """Every edit of CasADi's generated C is guarded by the versions it was written for: on another, the
    generated sqpmethod is not built (CasADi's in-process one, which reports its status, serves) and the
    fatrop edits leave the code as generated."""
    import casadi as ca

    from hitchpark.solvers import casadi_patches

    assert casadi_patches.casadi_tested(ca.__version__)  # the suite runs on a tested CasADi
    assert casadi_patches.casadi_tested("3.8.9") and not casadi_patches.casadi_tested("3.7.2")
    assert not casadi_patches.casadi_tested("4.0.0")
    monkeypatch.setattr(casadi_patches, "TESTED_CASADI", ())
    monkeypatch.setenv("HITCHPARK_CACHE", str(tmp_path / "cache"))
    nlp, equality = _stalling_nlp()
    solver = make_solver("sqp_c", nlp, equality)
    assert not isinstance(solver, GeneratedNLP)
    solver(x0=[0.0, 0.0], p=0.0, lbg=[3.0, 0.0], ubg=[np.inf, 0.0])
    assert solver.stats()["success"] is False
    source = "static int casadi_f0(const casadi_real** arg) {}\ncasadi_fatrop_solve(\n"
    assert casadi_patches.link_warm_duals(source) is None
    assert casadi_patches.link_stagewise(source, {}) is None
    function = "static int f(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {\n"
    assert casadi_patches.mark_unused_arguments(function) == function


def test_the_exported_functions_mark_their_unused_arguments():
    from hitchpark.solvers import casadi_patches

    function = "static int f(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {\n"
    release = "void f_release(int mem) {\n"
    marked = casadi_patches.mark_unused_arguments(function + "}\n" + release + "}\n")
    assert (
        marked
        == function + "  (void) arg; (void) res; (void) iw; (void) w; (void) mem;\n}\n" + release + "  (void) mem;\n}\n"
    )


def test_generated_route_runs_in_process_where_nothing_compiles(tmp_path, monkeypatch):
    monkeypatch.setenv("HITCHPARK_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("HITCHPARK_JIT", "0")
    nmpc = TrailerNMPC(VehicleTrailer(), NMPCSettings(kind="paper", solver="fatrop_c"))
    assert not isinstance(nmpc.solver, GeneratedNLP)
    assert nmpc.step(10.0, 3.5, 0.0, 0.0).ok
    assert not (tmp_path / "cache").exists()


@pytest.mark.slow
def test_unknown_input_to_a_generated_solver_is_refused(shared_jit_cache, paper_problems):
    controller, _ = paper_problems
    tr = controller.transcription
    solver = make_solver("fatrop_c", tr.nlp, list(tr.lbg == tr.ubg))
    with pytest.raises(RuntimeError, match="unknown solver inputs"):
        solver(x_guess=np.zeros(3))


def test_a_generated_function_gives_the_same_answers(shared_jit_cache, monkeypatch):
    """The planner's batch rollouts compiled to C: the same numbers as CasADi's virtual machine."""
    import casadi as ca

    from hitchpark.native import CompiledFunction, generated_function

    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    step = ca.Function("step", [x, u], [ca.vertcat(x[0] + 0.1 * ca.cos(x[1]) * u, ca.atan2(ca.sin(x[1] + u), 1.0))])
    batch = step.map(4).mapaccum(10)
    compiled_batch = generated_function(batch)
    assert isinstance(compiled_batch, CompiledFunction) and compiled_batch.name() == batch.name()
    rng = np.random.default_rng(3)
    for _ in range(3):
        x0, us = rng.normal(size=(2, 4)), rng.normal(size=(1, 40))
        np.testing.assert_allclose(
            np.asarray(compiled_batch(x0, us)), np.asarray(batch(x0, us)), rtol=1e-12, atol=1e-12
        )
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("compiled again despite the cache"))
    assert isinstance(generated_function(batch), CompiledFunction)  # loaded from the cache the second time


@pytest.mark.slow
def test_compiled_code_is_shared_safely_by_threads_and_pickles(shared_jit_cache, paper_problems):
    """ctypes lets threads run during a call: each call's buffers must not be overwritten by another's."""
    import pickle
    import threading

    import casadi as ca

    from hitchpark.native import CompiledFunction, generated_function

    x = ca.SX.sym("x", 3)
    f = ca.Function("twist", [x], [ca.vertcat(ca.sin(x[0]) * x[1], ca.cos(x[2]) + x[0] ** 2)])
    compiled_f = generated_function(f)
    assert isinstance(compiled_f, CompiledFunction)
    inputs = [np.random.default_rng(k).normal(size=3) for k in range(2)]
    expected = [np.asarray(f(v)) for v in inputs]
    wrong = []

    def hammer(k: int) -> None:
        for _ in range(3000):
            if not np.array_equal(compiled_f(inputs[k]), expected[k]):
                wrong.append(k)

    threads = [threading.Thread(target=hammer, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == []
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(compiled_f))(inputs[0]), expected[0])

    controller, problems = paper_problems
    tr = controller.transcription
    solver = make_solver("fatrop_c", tr.nlp, list(tr.lbg == tr.ubg))
    copy = pickle.loads(pickle.dumps(solver))
    assert isinstance(copy, GeneratedNLP)
    assert float(copy(**problems[0].inputs())["f"]) == float(solver(**problems[0].inputs())["f"])


def test_a_matrix_argument_must_have_its_shape(shared_jit_cache):
    import casadi as ca

    from hitchpark.native import generated_function

    m = ca.SX.sym("m", 2, 2)
    f = generated_function(ca.Function("trace_ish", [m], [m[0, 1] - m[1, 0]]))
    a = np.array([[1.0, 2.0], [3.0, 4.0]])
    assert np.asarray(f(a)).item() == -1.0  # column-major inside, the NumPy matrix as given
    with pytest.raises(ValueError, match="shape"):
        f(a.ravel())  # a flat array would be read in some order: refused, as CasADi does


@pytest.mark.slow
@pytest.mark.parametrize(("route", "ocp"), [("fatrop_c", "full"), ("sqp_c", "paper"), ("fatrop_c", "obstacles")])
def test_generated_routes_reach_the_reference_optimum(
    shared_jit_cache, route, ocp, paper_problems, full_problems, obstacle_problems, ipopt_answers
):
    controller, problems = _problems(ocp, paper_problems, full_problems, obstacle_problems)
    tr = controller.transcription
    equality = list(tr.lbg == tr.ubg)
    solver = make_solver(route, tr.nlp, equality, transcription=tr)  # fatrop: its functions stage by stage
    assert isinstance(solver, GeneratedNLP)
    reference = ipopt_answers(ocp, controller, problems)  # IPOPT in-process, uncompiled, as in every test here
    for problem, (ok, w, f), (_, w_ref, f_ref) in zip(problems, _solve_all(solver, problems), reference, strict=True):
        assert ok
        assert f == pytest.approx(f_ref, rel=1e-5, abs=1e-9)
        np.testing.assert_allclose(tr.unpack(w, problem.p)[1][0], tr.unpack(w_ref, problem.p)[1][0], atol=2e-4)


def test_a_plant_with_a_compiled_step_pickles_and_steps_the_same(shared_jit_cache):
    import pickle

    from hitchpark.model.plant import Command, Plant, PlantSettings
    from hitchpark.model.state import State

    plant = Plant(PlantSettings(), VehicleTrailer(), State(6.0, 1.0, 0.3, 0.1), 0.1)
    copy = pickle.loads(pickle.dumps(plant))
    for command in (Command(-0.5, 0.2), Command(-1.0, -0.3)):
        assert plant.apply(command) == copy.apply(command)
    np.testing.assert_array_equal(plant.state.as_array(), copy.state.as_array())


@pytest.mark.slow
def test_nothing_compiles_once_the_planners_clock_runs_among_obstacles(jit_cache, monkeypatch):
    """On a cold cache the planner's functions compile (seconds): its batch rollouts, and the end-game's pursuits,
    one library per size of reference, all before the safety net's clock starts. The search's budget is a count, so
    a cold cache finds the warm cache's path, to the bit."""
    from hitchpark import native
    from hitchpark.planning import plan, planner

    clock = {"running": False}
    built_late: list[str] = []
    real_prepare, real_cached = planner.prepare, native.cached_library

    def prepare(*args):
        prepared = real_prepare(*args)
        clock["running"] = True
        return prepared

    def cached(name, key, build, rebuild=False):
        def recorded(*args):
            if clock["running"]:
                built_late.append(name)
            return build(*args)

        return real_cached(name, key, recorded, rebuild)

    monkeypatch.setattr(planner, "prepare", prepare)
    monkeypatch.setattr(native, "cached_library", cached)
    assert not jit_cache[0].exists()
    native._native.cache_clear()  # as in a fresh process: functions another test loaded are loaded again
    scenario = builtin_scenario("driveway")
    margin = scenario.settings.success.min_clearance_m + scenario.settings.process.plan_margin_m
    settings = replace(scenario.settings.planner, min_clearance_m=margin)
    found = []
    for _ in range(2):  # on a cold cache, then on a warm one
        clock["running"] = False
        found.append(plan(scenario.vehicle, scenario.start, scenario.goal, scenario.scene, settings))
    assert any(jit_cache[0].iterdir()), "the planner's functions were compiled"
    assert built_late == []
    cold, warm = found
    assert cold.status == warm.status == "found"
    for column, values in warm.path.items():
        np.testing.assert_array_equal(cold.path[column], values, err_msg=column)
