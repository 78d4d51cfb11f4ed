"""fatrop's iterations per recorded NMPC problem at several horizons: why the cost grows past N.

    python benchmarks/fatrop_iterations.py OCP N [N ...]

For each horizon N, records the problems the default controller of ``OCP`` (``paper``, ``full``,
``obstacles`` or ``tracking``, as ``hitchpark bench`` names them) poses from the first 4 of bench's
closed-loop starts, solves each with the in-process ``fatrop`` route (the default ``fatrop_c`` is the same
solver generated to C, which reports no iteration count) and prints the iterations (median, mean, p90,
max) and the default route's median time per call and per iteration, and what one evaluation of the exact Hessian of the
Lagrangian costs compiled (fatrop evaluates it once an iteration). A measurement, not a test.
"""

from __future__ import annotations

import argparse
import time

import casadi as ca
import numpy as np

from hitchpark.app.bench import BENCH_OCPS, _time_route, record_problems
from hitchpark.control.solvers import ROUTES, quiet_stderr
from hitchpark.model import VehicleTrailer
from hitchpark.native import generated_function


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ocp", choices=sorted(BENCH_OCPS))
    parser.add_argument("horizons", type=int, nargs="+")
    args = parser.parse_args()
    ocp = BENCH_OCPS[args.ocp]
    for n in args.horizons:
        controller, problems = record_problems(ocp, VehicleTrailer(), ocp.starts(4), n)
        tr = controller.transcription
        problems = [p for p in problems if len(p.p) == tr.nlp["p"].numel()]
        plugin, options = ROUTES["fatrop"].factory(list(tr.lbg == tr.ubg))
        with quiet_stderr():
            solver = ca.nlpsol("fatrop_iterations", plugin, dict(tr.nlp), options)
        iterations = []
        for problem in problems:
            solver(**problem.inputs())
            iterations.append(solver.stats()["iter_count"])
        its = np.array(iterations)
        ms = float(np.median(_time_route(controller.solver, problems)[0]))
        print(
            f"N = {n}: {len(its)} problems; fatrop iterations median {np.median(its):g}, mean {its.mean():.2f}, "
            f"p90 {np.percentile(its, 90):g}, max {its.max()}; default route {ms:.3f} ms a call, "
            f"{ms / np.median(its):.4f} ms an iteration"
        )
        hess_ms, instructions = _hessian_cost(tr.nlp, problems)
        print(
            f"        the exact Hessian of the Lagrangian, compiled: {instructions} instructions, "
            f"{hess_ms:.4f} ms an evaluation (one each iteration)"
        )


def _hessian_cost(nlp: dict, problems: list) -> tuple[float, int]:
    """What one evaluation of the NLP's Lagrangian Hessian costs, compiled to C as the generated route's is."""
    x, p, g = nlp["x"], nlp["p"], nlp["g"]
    lam = ca.SX.sym("lam", g.numel())
    hessian = ca.hessian(nlp["f"] + ca.dot(lam, g), x)[0]
    function = ca.Function("hess_l", [x, p, lam], [ca.densify(hessian)])
    compiled = generated_function(function)
    args = (problems[0].w0, problems[0].p, np.ones(g.numel()))
    compiled(*args)
    start = time.perf_counter()
    for _ in range(2000):
        compiled(*args)
    return (time.perf_counter() - start) / 2000 * 1e3, function.n_instructions()


if __name__ == "__main__":
    main()
