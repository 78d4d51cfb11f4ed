"""hitchpark's own structured NLP solver: an interior-point method whose Newton steps are a Riccati recursion.

fatrop, made for OCPs, keeps many blocks a stage (some 158 KiB a stage of the obstacle OCP), and at N = 80 an
iteration walks through more than a core's second-level cache holds: a stage costs a fifth more there than
at N = 10 (docs/performance.md). This solver (``riccati_ipm.c``, its method described at its top) keeps what a
stage needs together in one struct (11 KiB for the obstacle OCP, 4 KiB for the full one), in the work array
the caller hands it, and allocates nothing: the C an embedded computer would run. CasADi writes the stage's
functions (:func:`riccati_functions`: the transcription's own expressions, as :mod:`.stagewise` writes them)
to C, they and the solver are compiled into one library, and each call goes through
:class:`.generated.GeneratedNLP` with the calling convention of a CasADi ``nlpsol``: the same inputs and
outputs, multipliers included.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import casadi as ca

from ..native import build_library, cache_key, load_cached, resolved_compiler
from .casadi_patches import mark_unused_arguments
from .generated import GeneratedNLP
from .transcription import MultipleShooting, first_step_weight

__all__ = [
    "RICCATI_SOURCES",
    "checked_options",
    "riccati_functions",
    "riccati_nlpsol",
    "riccati_source",
    "riccati_standalone",
]

#: The solver's C, one unit in four files in this order (the method described at the top of the first).
RICCATI_SOURCES = tuple(
    Path(__file__).with_name(name)
    for name in ("riccati_ipm.c", "riccati_ipm_newton.inc", "riccati_ipm_search.inc", "riccati_ipm_solve.inc")
)


def riccati_source() -> str:
    """The solver's C: :data:`RICCATI_SOURCES` joined, as the in-process route compiles it and the package holds it."""
    return "".join(path.read_text(encoding="utf-8") for path in RICCATI_SOURCES)


#: The solver's options and their defaults: tolerance of the scaled optimality error, the barrier parameter
#: (fixed), the iteration limit, the least slack of a constraint at the start (the warm start's own
#: otherwise: where it is active, the slack starts this close to its bound), and whether each Newton step
#: takes Mehrotra's corrector (the step's second-order term in the complementarity). ``warm_iterations`` (opt-in,
#: None: off): the Newton steps a warm-started solve takes at most, its iterate then the answer (a success), as a
#: real-time iteration (``HP_WARM_ITER``); a cold start keeps ``max_iter``. ``whole_steps_only`` (with
#: ``warm_iterations``): the cap answers only a Newton step taken whole (primal and dual length 1); a step cut short
#: goes on to the next one taken whole or to the tolerance (``HP_WARM_WHOLE``).
DEFAULTS = {
    "tol": 1e-8,
    "mu": 1e-9,
    "max_iter": 300,
    "bound_push": 1e-9,
    "corrector": True,
    "warm_iterations": None,
    "whole_steps_only": False,
}


def riccati_functions(transcription: Any, prefix: str) -> dict[str, ca.Function] | None:
    """The stage functions the solver calls, dense outputs (column-major), keyed by the C's macro names.

    ``lin0/link/linN``: cost, its gradient, the dynamics and their Jacobian (not at N), the rows and their
    Jacobian in X (not at 0), the Hessian of the stage's share of the Lagrangian ``f + lam_g' g``. ``ev0/evk/evN``:
    cost, dynamics and rows alone. None where the transcription is not multiple shooting or has path
    constraints (rows that may change with k).
    """

    pr = transcription.problem
    if not isinstance(transcription, MultipleShooting) or pr.path_constraints:
        return None
    nx, nu, n_p = pr.n_x, pr.n_u, pr.n_p
    X, U, P = ca.SX.sym("X", nx), ca.SX.sym("U", nu), ca.SX.sym("P", n_p)
    lam_gap = ca.SX.sym("lam_gap", nx)
    row_list = pr.step_rows(X, P)[0]
    rows = ca.vertcat(*row_list) if row_list else ca.SX(0, 1)
    lam_rows = ca.SX.sym("lam_rows", rows.numel())
    XU = ca.vertcat(X, U)
    F = pr.discrete_dynamics(X, U)  # Eq. (48)
    cost, terminal = pr.stage_cost(X, U, P), pr.terminal_cost(X, P)
    H = ca.SX.sym("H")  # stage 0's step length where the OCP makes it a parameter (p's last)
    h_in = [H] if pr.first_step else []
    F0 = pr.discrete_dynamics(X, U, H) if pr.first_step else F
    cost0 = first_step_weight(pr, H) * cost if pr.first_step else cost
    # Each stage's share of the Lagrangian without the linear X_{k+1} of its gap (g's gap is X_{k+1} - F).
    first = cost0 - ca.dot(lam_gap, F0)
    middle = cost - ca.dot(lam_gap, F) + ca.dot(lam_rows, rows)
    last = terminal + ca.dot(lam_rows, rows)

    def dense(*parts: Any) -> list[Any]:
        return [ca.densify(part) for part in parts]

    def fn(name: str, inputs: list[Any], outputs: list[Any]) -> ca.Function:
        # Common subexpressions once (the trailer's sin and cos, 158 calls of libm in a stage's linearization,
        # are then 25): each merged node is the same operation on the same operands, so the same bits.
        return ca.Function(f"{prefix}{name}", inputs, dense(*outputs), {"cse": True})

    return {
        "HP_LIN0": fn(
            "lin0",
            [X, U, P, lam_gap, *h_in],
            [cost0, ca.gradient(cost0, XU), F0, ca.jacobian(F0, XU), ca.hessian(first, XU)[0]],
        ),
        "HP_LINK": fn(
            "link",
            [X, U, P, lam_gap, lam_rows],
            [cost, ca.gradient(cost, XU), F, ca.jacobian(F, XU), rows, ca.jacobian(rows, X), ca.hessian(middle, XU)[0]],
        ),
        "HP_LINN": fn(
            "linN",
            [X, P, lam_rows],
            [terminal, ca.gradient(terminal, X), rows, ca.jacobian(rows, X), ca.hessian(last, X)[0]],
        ),
        "HP_EV0": fn("ev0", [X, U, P, *h_in], [cost0, F0]),
        "HP_EVK": fn("evk", [X, U, P], [cost, F, rows]),
        "HP_EVN": fn("evN", [X, P], [terminal, rows]),
    }


#: The library's entry points around the solver: the calling convention of a generated CasADi function
#: (:class:`hitchpark.native.LibraryCall`) and the warm start and iteration count of :class:`.GeneratedNLP`.
_EXPORTS = """
static _Thread_local int hp_warm_flag;
static _Thread_local double hp_warm_floor = 1e-9;
static _Thread_local int hp_last_iterations;
CASADI_SYMBOL_EXPORT int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{
  struct hp_work* m = (struct hp_work*) w;
  int code = hp_solve(m, arg, res, hp_warm_flag, hp_warm_floor);
  hp_last_iterations = m->iterations;
  return code;
}}
CASADI_SYMBOL_EXPORT int {name}_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw, casadi_int* sz_w) {{
  *sz_arg = 8; *sz_res = 5; *sz_iw = 0;
  *sz_w = (casadi_int) (sizeof(struct hp_work) / sizeof(casadi_real)) + 1;
  return 0;
}}
CASADI_SYMBOL_EXPORT int {name}_checkout(void) {{ return 0; }}
CASADI_SYMBOL_EXPORT void {name}_release(int mem) {{ (void) mem; }}
CASADI_SYMBOL_EXPORT void {name}_set_warm(int warm, double floor) {{ hp_warm_flag = warm; hp_warm_floor = floor; }}
CASADI_SYMBOL_EXPORT int {name}_iterations(void) {{ return hp_last_iterations; }}
CASADI_SYMBOL_EXPORT int {name}_frees_initial(void) {{ return 1; }}
"""


def _config(transcription: Any, functions: Mapping[str, ca.Function], options: Mapping[str, Any]) -> str:
    """The C definitions :func:`riccati_source` is written against."""
    pr = transcription.problem
    n_rows = int(functions["HP_EVK"].size1_out(2))
    work = {
        "HP_SZ_ARG": max(f.sz_arg() for f in functions.values()),
        "HP_SZ_RES": max(f.sz_res() for f in functions.values()),
        "HP_SZ_IW": max(max(f.sz_iw() for f in functions.values()), 1),
        "HP_SZ_W": max(max(f.sz_w() for f in functions.values()), 1),
    }
    lines = {
        "HP_N": pr.horizon,
        "HP_NX": pr.n_x,
        "HP_NU": pr.n_u,
        "HP_NR": n_rows,
        "HP_NP": pr.n_p,
        "HP_H0": int(bool(pr.first_step)),
        "HP_TOL": repr(float(options["tol"])),
        "HP_MU": repr(float(options["mu"])),
        "HP_MAX_ITER": int(options["max_iter"]),
        "HP_BOUND_PUSH": repr(float(options["bound_push"])),
        "HP_CORRECTOR": int(options["corrector"]),
        **({} if options.get("warm_iterations") is None else {"HP_WARM_ITER": int(options["warm_iterations"])}),
        **({"HP_WARM_WHOLE": 1} if options.get("whole_steps_only") else {}),
        **work,
        **{macro: f.name() for macro, f in functions.items()},
    }
    return "\n" + "".join(f"#define {k} {v}\n" for k, v in lines.items())


def checked_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The solver's options, :data:`DEFAULTS` under ``options``; RuntimeError on an option it does not take or a
    value out of range."""
    settings = {**DEFAULTS, **(options or {})}
    unknown = sorted(set(settings) - set(DEFAULTS))
    if unknown:
        raise RuntimeError(f"unknown option {unknown[0]!r}; the options are {', '.join(DEFAULTS)}")
    for key in ("tol", "mu", "bound_push"):
        value = settings[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1:
            raise RuntimeError(f"option {key!r} must be a number in (0, 1), got {value!r}")
    if settings["mu"] >= settings["tol"]:
        raise RuntimeError(f"option 'mu' must be below 'tol' ({settings['tol']!r}), got {settings['mu']!r}")
    for key in ("corrector", "whole_steps_only"):
        if not isinstance(settings[key], bool):
            raise RuntimeError(f"option {key!r} must be True or False, got {settings[key]!r}")
    iterations = settings["max_iter"]
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise RuntimeError(f"option 'max_iter' must be a whole number of at least 1, got {iterations!r}")
    cap = settings["warm_iterations"]
    if cap is not None and (isinstance(cap, bool) or not isinstance(cap, int) or not 1 <= cap <= iterations):
        raise RuntimeError(f"option 'warm_iterations' must be None or a whole number in [1, max_iter], got {cap!r}")
    if settings["whole_steps_only"] and cap is None:
        raise RuntimeError("option 'whole_steps_only' needs 'warm_iterations' (the Newton steps before the cap)")
    return settings


def riccati_nlpsol(
    name: str, transcription: Any, options: Mapping[str, Any] | None = None, dual_floor: float = 1e-9
) -> GeneratedNLP | None:
    """The solver of ``transcription.nlp`` as a compiled library (from the cache when it can), or None where
    it cannot be built: no C compiler, no transcription or one it does not take (:func:`riccati_functions`).
    Raises RuntimeError on an option it does not take (:data:`DEFAULTS` names them) or a value out of range.
    """
    settings = checked_options(options)
    if transcription is None:
        return None
    compiler = resolved_compiler()
    functions = riccati_functions(transcription, f"{name}_")
    if compiler is None or functions is None:
        return None
    solver_c = riccati_source()
    text = _config(transcription, functions, settings) + solver_c + _EXPORTS.format(name=name)
    nlp = transcription.nlp

    def build(compiler: str, home: Path, library: Path) -> bool:
        main, *rest = functions.values()
        return build_library(main, (), compiler, home, library, rest, lambda source: source + text)

    graphs = "".join(function.serialize() for function in functions.values())  # their C, as CasADi will write it
    kind = "riccati-" + hashlib.sha256((text + graphs).encode()).hexdigest()[:16]
    key = cache_key("riccati", nlp, settings, kind=kind)
    sizes = (int(nlp["x"].numel()), int(nlp["p"].numel()), int(nlp["g"].numel()))
    return load_cached(name, key, build, lambda library: GeneratedNLP(library, name, *sizes, dual_floor))


def riccati_standalone(
    transcription: Any,
    prefix: str,
    options: Mapping[str, Any] | None = None,
    extra: Mapping[str, ca.Function] | None = None,
) -> tuple[str, str] | None:
    """The solver's C for a build of its own (``hitchpark export``): the definitions :func:`riccati_source` is
    written against (``#define`` lines, sized for ``extra`` too: more functions the caller's C calls with the
    solver's work arrays, keyed by the macro that names them) and one C file of the stage functions and
    ``extra``, as CasADi writes them, each function's unused arguments marked used (it then compiles without
    a warning). None where the transcription is not one the solver takes (:func:`riccati_functions`).
    """
    settings = checked_options(options)
    functions = riccati_functions(transcription, prefix)
    if functions is None:
        return None
    every = {**functions, **(extra or {})}
    generator = ca.CodeGenerator(f"{prefix}functions.c", {"main": False, "with_header": False})
    for function in every.values():
        generator.add(function)
    return _config(transcription, every, settings), mark_unused_arguments(generator.dump())
