"""``riccati_c`` with and without Mehrotra's corrector on the same recorded NMPC problems, IPOPT beside them.

    python benchmarks/riccati_corrector.py OCP N [N ...] [--starts S]

For each horizon N, records the problems the default controller of ``OCP`` (``paper``, ``full``, ``obstacles``
or ``tracking``, as ``hitchpark bench`` names them) poses from the first S (default 4, as bench's horizon
scaling; 12 are bench's own) of bench's closed-loop starts, then solves each, warm-started from the
multipliers the controller started it from, with ``riccati_c`` built with the corrector (the default) and
without it (``nmpc.solver_options = {corrector = false}``), and with IPOPT. Prints per build the iterations
(total, mean, median), the failures, the median time of a call, the largest difference of its answer from
IPOPT's, and the problems whose first move (the command the car is given) differs from IPOPT's by more than
1e-3, with both costs: a nonconvex problem may have more than one local optimum. A measurement, not a test.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hitchpark.app.bench import BENCH_OCPS, own_problems, record_problems
from hitchpark.model import VehicleTrailer
from hitchpark.solvers.registry import make_solver


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ocp", choices=sorted(BENCH_OCPS))
    parser.add_argument("horizons", type=int, nargs="+")
    parser.add_argument("--starts", type=int, default=4, metavar="S")
    args = parser.parse_args()
    ocp = BENCH_OCPS[args.ocp]
    for horizon in args.horizons:
        controller, recorded = record_problems(ocp, VehicleTrailer(), ocp.starts(args.starts), horizon)
        problems = own_problems(controller, recorded)
        tr = controller.transcription
        equality = list(tr.lbg == tr.ubg)
        floor = controller.settings.dual_floor
        reference = make_solver("ipopt", tr.nlp, equality)
        answers, costs = [], []
        for problem in problems:
            out = reference(**problem.inputs())
            answers.append(np.asarray(out["x"]).ravel())
            costs.append(float(out["f"]))
        print(f"{args.ocp} N = {horizon}: {len(problems)} problems")
        for corrector in (True, False):
            solver = make_solver(
                "riccati_c", tr.nlp, equality, {"corrector": corrector}, transcription=tr, dual_floor=floor
            )
            iterations, times, failures, diff, moved = [], [], 0, 0.0, []
            for index, (problem, x_ref) in enumerate(zip(problems, answers, strict=True)):
                start = time.perf_counter()
                out = solver(**problem.inputs(duals=True))
                times.append(time.perf_counter() - start)
                stats = solver.stats()
                iterations.append(stats.get("iter_count", 0))
                failures += not stats["success"]
                x = np.asarray(out["x"]).ravel()
                diff = max(diff, float(np.max(np.abs(x - x_ref))))
                move = np.max(np.abs(tr.unpack(x, problem.p)[1][0] - tr.unpack(x_ref, problem.p)[1][0]))
                if move > 1e-3:
                    moved.append(f"#{index} by {move:.3g} (cost {float(out['f']):.6g}, IPOPT's {costs[index]:.6g})")
            its = np.array(iterations)
            print(
                f"  corrector {'on ' if corrector else 'off'}: iterations {its.sum()} (mean {its.mean():.2f}, median"
                f" {np.median(its):g}), failures {failures}, median {1e3 * np.median(times):.4f} ms a call, largest"
                f" difference from IPOPT's answer {diff:.1e}; first move off IPOPT's by more than 1e-3 on"
                f" {len(moved)} of {len(problems)}" + (": " + ", ".join(moved[:5]) if moved else ""),
                flush=True,
            )


if __name__ == "__main__":
    main()
