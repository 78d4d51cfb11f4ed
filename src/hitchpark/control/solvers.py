"""Solvers as a registry: a name -> a function that builds a CasADi ``nlpsol`` for a transcription.

Add a route with :func:`register_solver`; settings name solvers by these keys, and the
controller builds them here, never by checking names itself.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

import casadi as ca

from .compiled import compiled_nlpsol

__all__ = ["SOLVERS", "casadi_reason", "make_solver", "quiet_stderr", "register_solver", "solver_names"]

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
    with quiet_stderr():
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
