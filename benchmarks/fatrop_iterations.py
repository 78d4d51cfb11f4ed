"""fatrop's iterations per recorded NMPC problem at several horizons: why the cost grows past N.

    python benchmarks/fatrop_iterations.py OCP N [N ...]

For each horizon N, records the problems the default controller of ``OCP`` (``paper``, ``full``,
``obstacles`` or ``tracking``, as ``hitchpark bench`` names them) poses from the first 4 of bench's
closed-loop starts, solves each with the in-process ``fatrop`` route (the default ``fatrop_c`` is the same
solver generated to C, which reports no iteration count) and prints the iterations (median, mean, p90,
max) and the default route's median time per call and per iteration. A measurement, not a test.
"""

from __future__ import annotations

import argparse

import casadi as ca
import numpy as np

from hitchpark.app.bench import BENCH_OCPS, _time_route, record_problems
from hitchpark.control.solvers import ROUTES, quiet_stderr
from hitchpark.model import VehicleTrailer


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


if __name__ == "__main__":
    main()
