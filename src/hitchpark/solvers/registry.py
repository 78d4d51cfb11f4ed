"""Solvers as a registry of named routes over one transcription of an OCP.

A route is a CasADi NLP plugin with its options, built either in-process (its functions compiled
to C when ``jit``) or as the whole solver generated to C and compiled (:mod:`.generated`), or a solver
of hitchpark's own with a builder of its own (``riccati_c``, :mod:`.riccati`). Add one
with :func:`register_solver`; settings name routes by these keys, the controller builds them here
and ``hitchpark bench`` compares them on recorded problems, never by checking names themselves.
"""

from __future__ import annotations

import functools
import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import casadi as ca

from .compiled import compiled_nlpsol
from .generated import generated_nlpsol
from .riccati import DEFAULTS as RICCATI_DEFAULTS
from .riccati import riccati_nlpsol
from .stagewise import stagewise_functions

__all__ = [
    "COLD_ROUTES",
    "ROUTES",
    "Route",
    "casadi_reason",
    "cold_solver_names",
    "make_cold_solver",
    "make_solver",
    "quiet_stderr",
    "register_solver",
    "solver_names",
    "takes_duals",
    "takes_free_initial",
]

#: ``factory(equality) -> (CasADi plugin, default options)``; ``equality`` flags the constraints that
#: are equalities (structure-exploiting solvers need it). The user's ``solver_options`` go on top.
SolverFactory = Callable[[Sequence[bool]], tuple[str, dict[str, Any]]]

#: ``build(name, transcription, options, dual_floor) -> solver or None``: a route's own builder (not a
#: CasADi plugin); None where it cannot be built here (no compiler, a transcription it does not take).
#: Raises RuntimeError on options it does not accept.
SolverBuilder = Callable[[str, Any, Mapping[str, Any], float], Any]


@dataclass(frozen=True)
class Route:
    """A named way to solve the NLP: the plugin and options, and whether the whole solver is generated C."""

    name: str
    factory: SolverFactory
    generated: bool = False
    structured: bool = False  # exploits the stages of multiple shooting: single shooting has none
    build: SolverBuilder | None = None  # a solver of hitchpark's own (the factory's plugin names it)
    stand_in: str | None = None  # the route built where ``build`` cannot build

    @property
    def summary(self) -> str:
        """The first line of the factory's docstring."""
        return (self.factory.__doc__ or self.name).strip().splitlines()[0]


ROUTES: dict[str, Route] = {}


def register_solver(
    name: str,
    generated: bool = False,
    structured: bool = False,
    build: SolverBuilder | None = None,
    stand_in: str | None = None,
) -> Callable[[SolverFactory], SolverFactory]:
    """Decorator: register a factory returning ``(plugin, default options)`` under ``name``.

    ``generated``: the route is the whole solver as compiled C (in-process where nothing compiles).
    ``structured``: it needs the stage structure of the multiple-shooting transcription.
    ``build``: the route is a solver of hitchpark's own, built so (:data:`SolverBuilder`); where it cannot
    be, the route ``stand_in`` is built instead (with its own defaults).
    """

    def put(factory: SolverFactory) -> SolverFactory:
        ROUTES[name] = Route(name, factory, generated, structured, build, stand_in)
        return factory

    return put


def solver_names() -> tuple[str, ...]:
    return tuple(ROUTES)


@register_solver("ipopt")
def _ipopt(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """Interior point, warm-started: the reference."""
    return "ipopt", {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.tol": 1e-9,
        "ipopt.max_iter": 300,
        "ipopt.warm_start_init_point": "yes",
        "ipopt.warm_start_bound_push": 1e-9,
        "ipopt.warm_start_mult_bound_push": 1e-9,
        "ipopt.mu_init": 1e-4,
    }


@register_solver("sqp")
def _sqp(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """CasADi sqpmethod with the qrqp active-set QP solver and the exact, eigenvalue-clipped Hessian."""
    return "sqpmethod", {
        "print_time": False,
        "print_header": False,
        "print_iteration": False,
        "print_status": False,
        "qpsol": "qrqp",
        "qpsol_options": {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False},
        "hessian_approximation": "exact",
        "convexify_strategy": "eigen-clip",
        "max_iter": 100,
        # Primal 1e-9 is below what the Euler equalities (terms ~10) reach in double precision: the SQP
        # then stalls at the optimum with Search_Direction_Becomes_Too_Small. 1e-8 / 1e-8 converge.
        "tol_pr": 1e-8,
        "tol_du": 1e-8,
        "error_on_fail": False,
    }


_CASADI_SOURCE = re.compile(r"^\.\.\./casadi/\S+:\d+:\s*")


def casadi_reason(exc: BaseException) -> str:
    """The root cause of a CasADi error on one line: its last located message, without the source location."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    located = [i for i, line in enumerate(lines) if _CASADI_SOURCE.match(line)]
    if not located:
        return lines[-1] if lines else type(exc).__name__
    i = located[-1]
    text = _CASADI_SOURCE.sub("", lines[i])
    if text.endswith(":") and i + 1 < len(lines):  # 'Assertion "..." failed:' and the reason on the next line
        text = lines[i + 1] if text.startswith("Assertion") else f"{text} {lines[i + 1]}"
    return re.sub(r"\s*\[\.\.\./casadi/\S+\]$", "", text)


@contextmanager
def quiet_stderr() -> Iterator[list[str]]:
    """Hold back what C code writes to the standard error (CasADi's warnings) while the block runs.

    Yields a list that receives the held text. If the block raises, the text is dropped: the
    exception says what went wrong, on one line. Otherwise it is written out after the block.
    """
    held: list[str] = []
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no real standard error (an embedding host): nothing to hold back
        yield held
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        failed = False
        try:
            yield held
        except BaseException:
            failed = True
            raise
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            held.append(tmp.read().decode("utf-8", "replace"))
            if not failed and held[0]:
                sys.stderr.write(held[0])


def takes_duals(solver: Any) -> bool:
    """Whether ``solver`` starts from given multipliers to its gain: a generated fatrop solver built with its
    warm start (:class:`.generated.GeneratedNLP`). CasADi's own solvers take ``lam_x0`` and ``lam_g0`` too,
    but the in-process fatrop ignores them and sqpmethod, given fatrop's, failed on recorded problems: they
    get none."""
    return bool(getattr(solver, "warm_duals", False))


def takes_free_initial(solver: Any) -> bool:
    """Whether ``solver``, a structured one, takes a problem that frees components of X_0 from the measured
    state (a stage's free-steer problem, :meth:`.Transcription.bounds`): a compiled ``riccati_c``."""
    return bool(getattr(solver, "frees_initial", False))


def make_solver(
    name: str,
    nlp: Mapping[str, Any],
    equality: Sequence[bool],
    options: Mapping[str, Any] | None = None,
    jit: bool = False,
    transcription: Any = None,
    dual_floor: float | None = None,
) -> Any:
    """A CasADi ``nlpsol`` of the registered solver ``name`` for ``nlp``, its defaults under ``options``.

    ``jit``: compile the NLP's functions to C and cache the solver on disk (:mod:`.compiled`). A generated
    route is compiled whole whatever ``jit`` says (:mod:`.generated`); given the ``transcription`` whose
    NLP ``nlp`` is, a generated structured route evaluates the NLP's functions stage by stage
    (:mod:`.stagewise`). ``dual_floor``: the least bound multiplier of a generated fatrop solver started
    from given multipliers (:class:`.generated.GeneratedNLP`; None: 1e-9, the full kind's), and of
    ``riccati_c``; other routes take no such start. A route of hitchpark's own (``build``) needs the
    ``transcription``; where it cannot be built, its ``stand_in`` is.
    """
    route = ROUTES[name]
    plugin, opts = route.factory(equality)
    opts.update(options or {})
    floor = 1e-9 if dual_floor is None else dual_floor
    if route.build is not None:
        built = route.build(f"hitchpark_{name}", transcription, opts, floor)
        if built is not None or route.stand_in is None:
            return built
        return make_solver(route.stand_in, nlp, equality, None, jit, transcription, dual_floor)
    with quiet_stderr():
        if route.generated:
            stages = None
            if transcription is not None and route.structured:
                stages = functools.partial(stagewise_functions, transcription)
            return generated_nlpsol(
                f"hitchpark_{name}",
                plugin,
                nlp,
                opts,
                stages=stages,
                dual_floor=floor,
            )
        if jit:
            return compiled_nlpsol(f"nmpc_{name}", plugin, nlp, opts)
        return ca.nlpsol(f"nmpc_{name}", plugin, dict(nlp), opts)


@register_solver("fatrop", structured=True)
def _fatrop(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """fatrop: an interior-point method that exploits the stage structure of an OCP (multiple shooting)."""
    return "fatrop", {
        "print_time": False,
        "structure_detection": "auto",
        "equality": [bool(e) for e in equality],
        "debug": False,
        "fatrop.print_level": 0,
        # From a warm start the first barrier parameter sets the iterations. On recorded closed-loop problems
        # at N = 10 (``python benchmarks/fatrop_iterations.py OCP 10 --set fatrop.mu_init=1e-8``), 1e-9 takes a
        # mean of 4.09 / 5.35 / 7.28 / 4.73 iterations on the paper / full / obstacle / tracking OCPs where 1e-8
        # took 4.85 / 5.98 / 7.82 / 5.58 (and 1e-4 took 11 at N = 80 on the paper's); below 1e-9 gains nothing
        # and fails more at N = 80. The tolerance stays 1e-8: at 1e-6 a reverse stage stopped on speeds of
        # 1.5 mm/s that IPOPT's optimum keeps (the stop rule compares with 1 mm/s).
        "fatrop.tol": 1e-8,
        "fatrop.max_iter": 300,
        "fatrop.mu_init": 1e-9,
        # Start close to the warm start's bounds. (fatrop has no warm_start_init_point: given, the first
        # call of each solver raised and IPOPT stood in.)
        "fatrop.bound_push": 1e-9,
    }


@register_solver("fatrop_c", generated=True, structured=True)
def _fatrop_c(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """fatrop generated to C with the OCP and compiled, called through ctypes: no CasADi layer per call."""
    return _fatrop(equality)


@register_solver("sqp_c", generated=True)
def _sqp_c(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """The sqp route (sqpmethod, qrqp, exact eigenvalue-clipped Hessian) generated to C and compiled."""
    return _sqp(equality)


@register_solver("sqp_bfgs")
def _sqp_bfgs(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """sqpmethod with qrqp and a limited-memory BFGS Hessian: no second derivatives."""
    plugin, options = _sqp(equality)
    return plugin, {**options, "hessian_approximation": "limited-memory", "max_iter": 200}


@register_solver("riccati_c", structured=True, build=riccati_nlpsol, stand_in="fatrop_c")
def _riccati_c(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """hitchpark's own interior-point method, its Newton steps a Riccati recursion, compiled with the OCP."""
    return "riccati", dict(RICCATI_DEFAULTS)


#: Routes for an NLP solved from a start of its own, not warm-started from a last solution (the planner's
#: refinement of a searched path, :mod:`hitchpark.planning.refine`): ``factory(equality) -> (plugin, options)``,
#: in-process (nothing to compile: an 80-step NLP took 29 s to compile for IPOPT, 65 s among obstacles, and 30 s as
#: a whole generated fatrop solver). The warm-started routes above are tuned to start near the bounds.
COLD_ROUTES: dict[str, SolverFactory] = {}


def _cold(name: str) -> Callable[[SolverFactory], SolverFactory]:
    def put(factory: SolverFactory) -> SolverFactory:
        COLD_ROUTES[name] = factory
        return factory

    return put


@_cold("fatrop")
def _fatrop_cold(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """fatrop on the NLP's stages, from its own start."""
    return "fatrop", {
        "print_time": False,
        "structure_detection": "auto",
        "equality": list(equality),
        "debug": False,
        "fatrop.print_level": 0,
        "fatrop.tol": 1e-8,
        "fatrop.max_iter": 200,
    }


@_cold("ipopt")
def _ipopt_cold(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """IPOPT, the reference: on the planner's refinement the same optimum as fatrop's (to about 1e-6 m) in the
    same iterations, 1.3 to 2.5 times slower."""
    return "ipopt", {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": 200,
        "ipopt.tol": 1e-8,
        "ipopt.bound_relax_factor": 0.0,
    }


def cold_solver_names() -> tuple[str, ...]:
    return tuple(COLD_ROUTES)


def make_cold_solver(name: str, label: str, nlp: Mapping[str, Any], equality: Sequence[bool]) -> Any:
    """A CasADi ``nlpsol`` named ``label`` of the cold-start route ``name`` (:data:`COLD_ROUTES`) for ``nlp``."""
    plugin, options = COLD_ROUTES[name](equality)
    return ca.nlpsol(label, plugin, dict(nlp), options)
