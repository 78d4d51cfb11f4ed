"""The NLP's functions stage by stage (hitchpark.solvers.stagewise): CasADi's sparsity and numbers, for every
OCP the controllers solve; refused where the layout is not theirs; linked into a generated solver only
where its code has the expected hooks."""

from __future__ import annotations

import functools
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from hitchpark.control import NMPCSettings, make_nmpc
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model import VehicleTrailer
from hitchpark.solvers.casadi_patches import link_stagewise
from hitchpark.solvers.registry import ROUTES
from hitchpark.solvers.stagewise import ORACLE, _agree, stagewise_functions


def _solver(tr):
    plugin, options = ROUTES["fatrop"].factory(list(tr.lbg == tr.ubg))
    return ca.nlpsol("s", plugin, tr.nlp, options)


def _transcription(kind: str, horizon: int):
    """The transcription of the paper's OCP, or of the full model's: parking, tracking a reference, or keeping
    clear of the campsite's trees (rows on every X_k)."""
    if kind == "paper":
        return make_nmpc(VehicleTrailer(), NMPCSettings(kind="paper", horizon=horizon)).transcription
    return _keeping_clear(horizon)._program_for(kind == "tracking", lines=kind == "obstacles").transcription


@functools.cache
def _keeping_clear(horizon: int):
    """The full model's NMPC keeping clear of the campsite's trees, which builds every OCP of the full kind at once
    (:meth:`FullNMPC.keep_clear`): one for the parking, tracking and obstacle OCPs of each horizon, whose tests read
    their transcriptions and change nothing in them."""
    sc = builtin_scenario("campsite")
    controller = make_nmpc(sc.vehicle, replace(sc.settings.nmpc, kind="full", horizon=horizon))
    controller.keep_clear(sc.scene, 0.2)
    return controller


@pytest.mark.parametrize("kind", ["paper", "full", "tracking", "obstacles"])
@pytest.mark.parametrize("horizon", [1, 2, 7])
def test_the_stage_functions_give_casadis_sparsity_and_numbers(kind, horizon):
    tr = _transcription(kind, horizon)
    if kind != "paper":
        rows = tr.problem.step_rows(ca.SX.sym("x", tr.problem.n_x), ca.SX.sym("p", tr.problem.n_p))[0]
        assert (tr.problem.n_p > 0) == (kind != "full") and bool(rows) == (kind == "obstacles")
    solver = _solver(tr)
    functions = stagewise_functions(tr, solver, "t_")
    assert functions is not None and set(functions) == set(ORACLE)
    rng = np.random.default_rng(horizon)
    for name, mine in functions.items():
        theirs = solver.get_function(name)
        assert mine.name() == f"t_{name.removeprefix('nlp_')}"
        for _ in range(3):  # points of their own, not the one the build checked
            args = [rng.normal(0.0, 0.7, theirs.size_in(i)) for i in range(theirs.n_in())]
            a, b = theirs.call(args), mine.call(args)
            for x, y in zip(a, b, strict=True):
                assert x.sparsity() == y.sparsity()
                np.testing.assert_allclose(np.asarray(y.nonzeros()), np.asarray(x.nonzeros()), rtol=1e-12, atol=1e-12)


def test_a_problem_with_path_constraints_keeps_casadis_functions():
    controller = make_nmpc(VehicleTrailer(), NMPCSettings(kind="full", horizon=3))
    tr = controller.transcription
    tr.problem.path_constraints.append(lambda x, u, k: (x[0] + k, -10.0, 10.0))  # k-dependent: no stage function
    try:
        assert stagewise_functions(tr, _solver(tr), "t_") is None
    finally:
        tr.problem.path_constraints.clear()


def test_functions_that_disagree_with_casadis_are_refused():
    tr = _transcription("full", 3)
    solver = _solver(tr)
    functions = stagewise_functions(tr, solver, "t_")
    assert functions is not None and _agree(solver, functions)
    x, p = ca.MX.sym("x", tr.nlp["x"].numel()), ca.MX.sym("p", tr.nlp["p"].numel())
    wrong = ca.Function("t_f", [x, p], [functions["nlp_f"](x, p) * (1.0 + 1e-6)])
    assert not _agree(solver, {**functions, "nlp_f": wrong})


def test_generated_code_without_the_hooks_is_left_as_generated():
    tr = _transcription("paper", 2)
    functions = stagewise_functions(tr, _solver(tr), "t_")
    assert functions is not None
    hooks = "".join(f"  p.{k}.eval = casadi_f{i};\n" for i, k in enumerate(ORACLE[:-1], start=2))
    grad = "/* nlp_grad:(x) */\nstatic int casadi_f1(int a) {}\n"
    grad += "  if (casadi_f1(d->arg, d->res, d->iw, d->w, 0)) return 1;\n"
    source = "static int casadi_f0(const casadi_real** arg, ...) {\n" + hooks + grad + "}\n"
    linked = link_stagewise(source, functions)
    assert linked is not None
    assert "p.nlp_hess_l.eval = t_hess_l_cb;" in linked and "if (t_grad_cb(d->arg" in linked
    assert linked.index("static int t_hess_l_cb") < linked.index("static int casadi_f0(")
    assert link_stagewise(source.replace("p.nlp_jac_g.eval", "p.nlp_jac.eval"), functions) is None
    assert link_stagewise(source.replace("static int casadi_f0(", "static int casadi_f9("), functions) is None
