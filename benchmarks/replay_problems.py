"""Record the NMPC problems of one OCP to a file, then solve them again from it: for profilers.

    python benchmarks/replay_problems.py record OCP N FILE.npz
    python benchmarks/replay_problems.py solve OCP N FILE.npz [--limit K] [--repeat R]

``record`` runs the first 4 of ``hitchpark bench``'s closed-loop starts of ``OCP`` (``paper``, ``full`` or
``obstacles``) with the default controller at horizon N and saves every problem that controller's solver
was given (start, parameters, bounds, the multipliers it started from). ``solve`` builds the same
controller's solver without running any loop, solves the file's first K problems R times over with the
default route (from the recorded multipliers, as the controller does) and prints the time a call, the
iterations and the time per iteration and stage. Only the solves run after the solver is built, so a
profiler sees them alone; for instance callgrind's instruction counts and cache simulation (valgrind is
not a dependency of hitchpark), with this machine's first-level data cache and its second-level cache
of 2 MiB a core, counting only inside fatrop's solve:

    valgrind --tool=callgrind --cache-sim=yes --D1=49152,12,64 --LL=2097152,16,64 \
        --toggle-collect=fatrop_ocp_c_solve python benchmarks/replay_problems.py solve obstacles 80 o80.npz --limit 40

(callgrind's summary: ``I refs`` are instructions, ``LLd misses`` the data's misses of that 2 MiB cache).
A measurement, not a test. An existing FILE is not overwritten.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from hitchpark.app.bench import BENCH_OCPS, own_problems, record_problems
from hitchpark.control.receding import NLPProblem
from hitchpark.maneuver.process import predicted_clearance_m
from hitchpark.model import VehicleTrailer

#: The OCPs whose solver can be built without a loop (tracking's parameters come from a planned path).
OCPS = ("paper", "full", "obstacles")
FIELDS = ("p", "w0", "lbx", "ubx", "lbg", "ubg")


def fail(message: str) -> NoReturn:
    print(f"replay_problems: {message}", file=sys.stderr)
    raise SystemExit(2)


def record(ocp_name: str, horizon: int, path: Path) -> None:
    ocp = BENCH_OCPS[ocp_name]
    controller, problems = record_problems(ocp, VehicleTrailer(), ocp.starts(4), horizon)
    own = own_problems(controller, problems)
    if not own:
        fail(f"the closed loops of {ocp_name} at N = {horizon} posed no problem to record")
    duals = np.array([p.lam_x0 is not None and p.lam_g0 is not None for p in own])
    arrays: dict[str, Any] = {name: np.stack([getattr(p, name) for p in own]) for name in FIELDS}
    for name, size in (("lam_x0", len(own[0].w0)), ("lam_g0", len(own[0].lbg))):
        arrays[name] = np.stack([np.full(size, np.nan) if getattr(p, name) is None else getattr(p, name) for p in own])
    arrays["duals"] = duals
    # Written under a name of its own, then linked to FILE only if FILE still does not exist: a user's file
    # is never overwritten, and no half-written file is left behind.
    handle, name = tempfile.mkstemp(suffix=".npz", prefix=f".{path.name}.", dir=path.parent)
    partial = Path(name)
    try:
        with os.fdopen(handle, "wb") as out:
            np.savez(out, **arrays)
        os.link(partial, path)
    except FileExistsError:
        fail(f"{path} appeared while recording; not overwritten")
    finally:
        partial.unlink(missing_ok=True)
    print(f"{ocp_name} N = {horizon}: {len(own)} problems ({int(duals.sum())} with multipliers) -> {path}")


def load(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a file ``record`` wrote."""
    try:
        with np.load(path) as archive:
            data = dict(archive)
    except (OSError, ValueError) as exc:
        fail(f"{path} is not a file of recorded problems (from replay_problems.py record): {type(exc).__name__}")
    missing = [name for name in (*FIELDS, "lam_x0", "lam_g0", "duals") if name not in data]
    if missing:
        fail(f"{path} is not a file of recorded problems: no {', '.join(missing)}")
    return data


def solve(ocp_name: str, horizon: int, path: Path, limit: int | None, repeat: int) -> None:
    data = load(path)  # before anything is built: a wrong file fails at once
    ocp = BENCH_OCPS[ocp_name]
    settings = ocp.settings(horizon)
    controller, _ = record_problems(ocp, VehicleTrailer(), [], horizon)  # the controller, no loop run
    if settings.nmpc.kind == "full":  # the obstacle OCP's lines, as the planned process asks for them
        controller.keep_clear(ocp.starts(1)[0].scene, predicted_clearance_m(settings))
    tr = controller.transcription
    n = len(data["p"]) if limit is None else min(limit, len(data["p"]))
    if data["p"].shape[1] != tr.nlp["p"].numel() or data["w0"].shape[1] != tr.nlp["x"].numel():
        fail(
            f"{path} holds problems of {data['w0'].shape[1]} variables and {data['p'].shape[1]} parameters; "
            f"{ocp_name} at N = {horizon} has {tr.nlp['x'].numel()} and {tr.nlp['p'].numel()}"
        )
    problems = []
    for i in range(n):
        duals = bool(data["duals"][i])
        extra = {"lam_x0": data["lam_x0"][i], "lam_g0": data["lam_g0"][i]} if duals else {}
        problems.append(NLPProblem(**{name: data[name][i] for name in FIELDS}, **extra))
    solver = controller.solver  # the controller's own, as hitchpark bench times it
    inputs = [problem.inputs(duals=True) for problem in problems]
    iterations, failures = 0, 0
    start = time.perf_counter()
    for _ in range(repeat):
        for given in inputs:
            solver(**given)
            stats = solver.stats()
            iterations += int(stats.get("iter_count", 0))
            failures += not stats.get("success", False)
    spent = time.perf_counter() - start
    calls = n * repeat
    per_stage = 1e6 * spent / max(iterations, 1) / horizon
    counted = (
        f"{iterations / calls:.2f} iterations a call, {per_stage:.2f} us an iteration and stage"
        if iterations
        else "no iterations reported"
    )
    print(
        f"{ocp_name} N = {horizon}, {settings.nmpc.solver}: {calls} calls, {1e3 * spent / calls:.3f} ms a call, "
        f"{counted}, {failures} failed"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=("record", "solve"))
    parser.add_argument("ocp", choices=OCPS)
    parser.add_argument("horizon", type=int)
    parser.add_argument("file", type=Path)
    parser.add_argument("--limit", type=int, default=None, metavar="K")
    parser.add_argument("--repeat", type=int, default=1, metavar="R")
    args = parser.parse_args()
    if not 1 <= args.horizon <= 500:
        fail(f"the horizon must be 1 to 500 steps (nmpc.horizon's range), got {args.horizon}")
    if (args.limit is not None and args.limit < 1) or args.repeat < 1:
        fail("--limit and --repeat take a positive number")
    if args.mode == "record":
        if args.file.exists():
            fail(f"{args.file} exists; not overwritten (remove it or name another file)")
        if not args.file.parent.is_dir():
            fail(f"{args.file.parent} is not a folder")
        record(args.ocp, args.horizon, args.file)
    else:
        if not args.file.is_file():
            fail(f"{args.file} is not a file (make one with: replay_problems.py record ...)")
        solve(args.ocp, args.horizon, args.file, args.limit, args.repeat)


if __name__ == "__main__":
    main()
