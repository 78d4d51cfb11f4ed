"""Solvers as a registry: a name -> a function that builds a CasADi ``nlpsol`` for a transcription.

Add a route with :func:`register_solver`; settings name solvers by these keys, and the
controller builds them here, never by checking names itself.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import casadi as ca

from .compiled import compiled_nlpsol

__all__ = ["SOLVERS", "make_solver", "register_solver", "solver_names"]

#: ``name -> factory(equality) -> (CasADi plugin, default options)``; ``equality`` flags the constraints that
#: are equalities (structure-exploiting solvers need it). The user's ``solver_options`` go on top.
SolverFactory = Callable[[Sequence[bool]], tuple[str, dict[str, Any]]]

SOLVERS: dict[str, SolverFactory] = {}


def register_solver(name: str) -> Callable[[SolverFactory], SolverFactory]:
    """Decorator: register a factory returning ``(plugin, default options)`` under ``name``."""

    def put(factory: SolverFactory) -> SolverFactory:
        SOLVERS[name] = factory
        return factory

    return put


def solver_names() -> tuple[str, ...]:
    return tuple(SOLVERS)


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


def make_solver(
    name: str,
    nlp: Mapping[str, Any],
    equality: Sequence[bool],
    options: Mapping[str, Any] | None = None,
    jit: bool = False,
) -> Any:
    """A CasADi ``nlpsol`` of the registered solver ``name`` for ``nlp``, its defaults under ``options``.

    ``jit``: compile the NLP's functions to C and cache the solver on disk (:mod:`.compiled`).
    """
    plugin, opts = SOLVERS[name](equality)
    opts.update(options or {})
    if jit:
        return compiled_nlpsol(f"nmpc_{name}", plugin, nlp, opts)
    return ca.nlpsol(f"nmpc_{name}", plugin, dict(nlp), opts)


@register_solver("fatrop")
def _fatrop(equality: Sequence[bool]) -> tuple[str, dict[str, Any]]:
    """fatrop: an interior-point method that exploits the stage structure of an OCP (multiple shooting)."""
    return "fatrop", {
        "print_time": False,
        "structure_detection": "auto",
        "equality": [bool(e) for e in equality],
        "debug": False,
        "fatrop.print_level": 0,
        "fatrop.tol": 1e-8,
        "fatrop.max_iter": 300,
        "fatrop.mu_init": 1e-4,
        # Start close to the warm start's bounds: 7 iterations instead of 9 on a shifted plan. (fatrop has
        # no warm_start_init_point: given, the first call of each solver raised and IPOPT stood in.)
        "fatrop.bound_push": 1e-9,
    }
