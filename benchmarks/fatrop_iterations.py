"""fatrop's iterations per recorded NMPC problem at several horizons, and where an iteration's time goes.

    python benchmarks/fatrop_iterations.py OCP N [N ...] [--set KEY=VALUE ...] [--prediction-dt S] [--planes P]

For each horizon N, records the problems the default controller of ``OCP`` (``paper``, ``full``,
``obstacles`` or ``tracking``, as ``hitchpark bench`` names them) poses from the first 4 of bench's
closed-loop starts, solves each with the in-process ``fatrop`` route (fatrop's own start; the default
``fatrop_c`` is the same solver generated to C) and prints the iterations (median, mean, p90, max,
failures); then the generated route's own iterations, from the multipliers the controller started each
problem from (its warm start, :mod:`hitchpark.solvers.generated`) and from fatrop's own start; its
median time per call and per iteration (as the controller builds it: the NLP's functions stage by stage,
:mod:`hitchpark.solvers.stagewise`), and what each of CasADi's whole-horizon NLP functions costs per call
inside the solver (the in-process route with its functions compiled, CasADi's own timings): the
Lagrangian's Hessian and the constraints' Jacobian are evaluated once an iteration.

``--set KEY=VALUE`` puts a solver option on top of the route's (``--set fatrop.mu_init=1e-8``), for the
iterations and the timed route alike; ``--floor F`` starts the generated route's bound multipliers from at
least F (``nmpc.dual_floor``; default the controller's: 1e-9 full, 1 paper). The problems are the same
(recorded with the default). ``--prediction-dt S`` records and solves with that prediction step instead of the
OCP's (the full kind's is 0.3 s: N = 80 then sees 24 s ahead, N = 10 3 s); the last line compares the times of the
first and the last horizon. ``--planes P`` records and solves the obstacle OCP with P separating lines per
body and step (``nmpc.obstacle_planes``, default 3): the rows of a stage, and their data, scale with it. A
measurement, not a test.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

import numpy as np

from hitchpark.app.bench import BENCH_OCPS, own_problems, record_problems
from hitchpark.app.timing import time_route
from hitchpark.model import VehicleTrailer
from hitchpark.solvers.compiled import compiled_nlpsol
from hitchpark.solvers.registry import ROUTES, make_solver, quiet_stderr

#: The NLP's functions a fatrop iteration evaluates, as CasADi names them in a solver's statistics.
FUNCTIONS = ("nlp_hess_l", "nlp_jac_g", "nlp_g", "nlp_grad_f", "nlp_f")


def option(text: str) -> tuple[str, Any]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--set takes KEY=VALUE, got {text!r}")
    for kind in (int, float):
        try:
            return key, kind(value)
        except ValueError:
            pass
    return key, value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ocp", choices=sorted(BENCH_OCPS))
    parser.add_argument("horizons", type=int, nargs="+")
    parser.add_argument("--floor", type=float, default=None, metavar="F")
    parser.add_argument("--prediction-dt", type=float, default=None, metavar="S")
    parser.add_argument("--planes", type=int, default=None, metavar="P")
    parser.add_argument("--set", type=option, action="append", default=[], dest="options", metavar="KEY=VALUE")
    args = parser.parse_args()
    ocp = BENCH_OCPS[args.ocp]
    if args.prediction_dt is not None:
        ocp = replace(ocp, nmpc=replace(ocp.nmpc, prediction_dt=args.prediction_dt))
    if args.planes is not None:
        ocp = replace(ocp, nmpc=replace(ocp.nmpc, obstacle_planes=args.planes))
    times: dict[int, float] = {}
    overrides = dict(args.options)
    for n in args.horizons:
        controller, problems = record_problems(ocp, VehicleTrailer(), ocp.starts(4), n)
        tr = controller.transcription
        problems = own_problems(controller, problems)
        equality = list(tr.lbg == tr.ubg)
        plugin, options = ROUTES["fatrop"].factory(equality)
        with quiet_stderr():
            solver = compiled_nlpsol(f"fatrop_iterations_{n}", plugin, tr.nlp, {**options, **overrides})
            timed = make_solver(
                str(ocp.nmpc.solver),
                tr.nlp,
                equality,
                overrides,
                jit=bool(ocp.nmpc.jit),
                transcription=tr,
                dual_floor=controller.settings.dual_floor if args.floor is None else args.floor,
            )
        iterations, failures = [], 0
        spent: dict[str, float] = dict.fromkeys(FUNCTIONS, 0.0)
        calls: dict[str, int] = dict.fromkeys(FUNCTIONS, 0)
        for problem in problems:
            solver(**problem.inputs())
            stats = solver.stats()
            iterations.append(stats["iter_count"])
            failures += not stats["success"]
            for name in FUNCTIONS:
                spent[name] += stats.get(f"t_wall_{name}", 0.0)
                calls[name] += stats.get(f"n_call_{name}", 0)
        # The timed route's own count where it reports one (fatrop_c with its warm start of the multipliers):
        # from the multipliers the controller started each problem from, and from fatrop's own start.
        own: dict[str, list[int]] = {"the controller's multipliers": [], "fatrop's own start": []}
        for problem in problems:
            for label, given in zip(own, (problem.inputs(duals=True), problem.inputs()), strict=True):
                timed(**given)
                count = timed.stats().get("iter_count")
                if count is not None:
                    own[label].append(int(count))
        its = np.array(iterations)
        timed_calls = time_route(timed, problems)
        ms = float(np.median(timed_calls.wall))
        # The timed calls' own iterations (from the controller's multipliers).
        counted = np.isfinite(timed_calls.iterations)
        per_iteration = float(np.sum(timed_calls.wall[counted]) / max(np.sum(timed_calls.iterations[counted]), 1.0))
        times[n] = ms
        print(
            f"N = {n}: {len(its)} problems; fatrop iterations median {np.median(its):g}, mean {its.mean():.2f}, "
            f"p90 {np.percentile(its, 90):g}, max {its.max()}, failures {failures}; {ocp.nmpc.solver} "
            f"{ms:.3f} ms a call, {per_iteration:.4f} ms an iteration (their time over their iterations)"
        )
        for label, counts in own.items():
            if counts:
                print(
                    f"        {ocp.nmpc.solver} iterations from {label}: median {np.median(counts):g}, mean "
                    f"{np.mean(counts):.2f}, p90 "
                    f"{np.percentile(counts, 90):g}, max {max(counts)}"
                )
        per_call = ", ".join(f"{name} {1e6 * spent[name] / max(calls[name], 1):.2f}" for name in FUNCTIONS)
        print(f"        the NLP's functions in the solver [us a call]: {per_call}")
    if len(times) > 1:
        (first, t_first), (last, t_last) = min(times.items()), max(times.items())
        print(
            f"prediction step {ocp.nmpc.prediction_dt:g} s: N = {last} takes {t_last / t_first:.2f} times "
            f"N = {first} ({last / first:g} times the stages)"
        )


if __name__ == "__main__":
    main()
