"""Whole NLP solvers generated to C by CasADi, compiled, and called without CasADi's Python layer.

:mod:`.compiled` compiles the NLP's functions and leaves the solver in CasADi's virtual machine;
here CasADi writes the solver itself (fatrop's or sqpmethod's iterations, the QP, the functions)
as one C file, the system's C compiler makes a shared library of it, and each call fills
buffers laid out once and calls the library through :mod:`ctypes` (:mod:`hitchpark.native`). A call
takes about 0.11 ms against 0.29 ms for the same solver called through CasADi on the paper's OCP, 0.35
against 0.58 ms on the full one (``hitchpark bench``); on an embedded computer this C file is what runs.

Where nothing can be compiled (``HITCHPARK_JIT=0``, no C compiler, a compiler that refuses), or
when all :data:`~hitchpark.native.MAX_INSTANCES` memories of a library are taken by live solvers,
:func:`generated_nlpsol` returns the same plugin with the same options in-process: the same
answers to rounding, only slower.
"""

from __future__ import annotations

import ctypes
import hashlib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from ..native import LibraryCall, build_library, cache_key, load_cached, resolved_compiler
from .casadi_patches import (
    WARM_DUALS,
    casadi_tested,
    link_stagewise,
    link_warm_duals,
    report_sqp_failure,
    sqp_edit_text,
)
from .compiled import compiled_nlpsol

__all__ = ["WARM_SOURCE", "GeneratedNLP", "generated_nlpsol"]

#: Libraries the generated code of a plugin calls into (they ship inside CasADi's Python package).
_LINKED = {"fatrop": ("fatrop", "blasfeo"), "sqpmethod": ()}


class GeneratedNLP:
    """A compiled solver with the calling convention of a CasADi ``nlpsol``: ``solver(x0=, p=, lbx=, ...)``.

    Returns ``{"x", "f", "g", "lam_x", "lam_g"}`` (NumPy arrays, ``f`` a number); :meth:`stats` says whether
    the last call succeeded (the generated code returns nonzero when the solver did not converge).

    A fatrop solver built with :data:`WARM_SOURCE` (:attr:`warm_duals`) starts from the multipliers
    ``lam_x0`` and ``lam_g0`` when both are given (each bound's at least ``dual_floor``); fatrop's own
    start otherwise, and always in any other build.
    """

    _INPUTS = ("x0", "p", "lbx", "ubx", "lbg", "ubg", "lam_x0", "lam_g0")
    _OUTPUTS = ("x", "f", "g", "lam_x", "lam_g")

    def __init__(self, library: Path, name: str, n_x: int, n_p: int, n_g: int, dual_floor: float = 1e-9):
        self._lib = LibraryCall(library, name, (n_x, n_p, n_x, n_x, n_g, n_g, n_x, n_g), (n_x, 1, n_g, n_x, n_g))
        self._code = 0
        self._source = (library, name, n_x, n_p, n_g, dual_floor)
        self.dual_floor = float(dual_floor)
        # A library's own warm start and iteration count (:mod:`.riccati`), else the fatrop build's.
        lib = self._lib.library
        self._set_warm = getattr(lib, f"{name}_set_warm", None) or getattr(lib, "hitchpark_fatrop_set_warm", None)
        self._iterations = getattr(lib, f"{name}_iterations", None) or getattr(
            lib, "hitchpark_fatrop_last_iterations", None
        )
        if self._set_warm is not None:
            self._set_warm.argtypes = (ctypes.c_int, ctypes.c_double)
            self._set_warm.restype = None
        if self._iterations is not None:
            self._iterations.restype = ctypes.c_int
        self._iter_count: int | None = None
        self._frees_initial = getattr(lib, f"{name}_frees_initial", None) is not None

    @property
    def frees_initial(self) -> bool:
        """Whether this solver takes a problem that frees components of X_0 (their rows' bounds infinite):
        :mod:`.riccati`'s does, a generated fatrop or sqpmethod does not say."""
        return self._frees_initial

    @property
    def warm_duals(self) -> bool:
        """Whether this solver starts from given multipliers (a fatrop build with :data:`WARM_SOURCE`)."""
        return self._set_warm is not None

    def __reduce__(self) -> tuple[Any, ...]:
        return (GeneratedNLP, self._source)  # another process loads the library anew

    def __call__(self, **inputs: Any) -> dict[str, Any]:
        unknown = set(inputs) - set(self._INPUTS)
        if unknown:
            raise RuntimeError(f"unknown solver inputs {sorted(unknown)}; allowed: {', '.join(self._INPUTS)}")
        with self._lib.lock:  # the buffers are shared by the threads that call this solver
            for key, buffer in zip(self._INPUTS, self._lib.inputs, strict=True):
                value = inputs.get(key)
                if value is None:  # CasADi's defaults: free bounds, zero guesses and multipliers
                    buffer[:] = -np.inf if key in ("lbx", "lbg") else np.inf if key in ("ubx", "ubg") else 0.0
                else:
                    buffer[:] = np.asarray(value, dtype=float).ravel()
            if self._set_warm is not None:  # this thread's next solve, which follows under the lock
                warm = inputs.get("lam_x0") is not None and inputs.get("lam_g0") is not None
                self._set_warm(int(warm), self.dual_floor)
            self._code = self._lib.call()
            self._iter_count = int(self._iterations()) if self._iterations is not None else None
            out: dict[str, Any] = {k: v.copy() for k, v in zip(self._OUTPUTS, self._lib.outputs, strict=True)}
        out["f"] = float(out["f"][0])  # a number, as CasADi's 1x1 answer converts to one
        return out

    def stats(self) -> dict[str, Any]:
        """``success``, ``return_status`` and, from a build with :data:`WARM_SOURCE`, ``iter_count``."""
        ok = self._code == 0
        out: dict[str, Any] = {
            "success": ok,
            "return_status": "Solve_Succeeded" if ok else f"not converged (code {self._code})",
        }
        if self._iter_count is not None:
            out["iter_count"] = self._iter_count
        return out


#: fatrop's C interface with a warm start of the multipliers, linked into generated fatrop solvers.
WARM_SOURCE = Path(__file__).with_name("fatrop_warm.cpp")


def generated_nlpsol(
    name: str,
    plugin: str,
    nlp: Mapping[str, Any],
    options: Mapping[str, Any],
    stages: Callable[[ca.Function, str], Mapping[str, ca.Function] | None] | None = None,
    dual_floor: float = 1e-9,
) -> Any:
    """The solver ``casadi.nlpsol(name, plugin, nlp, options)`` as compiled C, from the cache when it can.

    ``stages(solver, prefix)``: the NLP's functions stage by stage (:func:`.stagewise.stagewise_functions`
    of the transcription), which fatrop's generated code then calls in place of CasADi's: code the size of
    a stage instead of the horizon's, the same numbers. A fatrop solver is linked with :data:`WARM_SOURCE`
    where it compiles, and then starts from given multipliers, each bound's at least ``dual_floor``
    (:class:`GeneratedNLP`). A generated sqpmethod reports a solve that did not converge as a failure, as
    CasADi's own does (:func:`~.casadi_patches.report_sqp_failure`). Falls back to the in-process CasADi solver
    (the same plugin and options) where nothing can be compiled.
    """
    compiler = resolved_compiler()
    stagewise = stages is not None and plugin == "fatrop"
    if compiler is not None and plugin in _LINKED:
        warm = plugin == "fatrop" and WARM_SOURCE.is_file() and casadi_tested()

        def build(compiler: str, home: Path, library: Path) -> bool:
            # error_on_fail: the generated function returns nonzero when the solver did not converge.
            solver = ca.nlpsol(name, plugin, dict(nlp), {**options, "error_on_fail": True})
            functions = stages(solver, f"{name}_stage_") if stages is not None and stagewise else None

            def edit(source: str) -> str | None:
                if plugin == "sqpmethod":
                    return report_sqp_failure(source)
                if functions:
                    linked = link_stagewise(source, functions)
                    if linked is None:
                        return None
                    source = linked
                return (link_warm_duals(source) or source) if warm else source

            # fatrop with the warm start of its multipliers; if that does not build, fatrop as it comes.
            for cxx in (WARM_SOURCE, None) if warm else (None,):
                extra = list(functions.values()) if functions else []
                if build_library(solver, _LINKED[plugin], compiler, home, library, extra, edit, cxx):
                    return True
            return False

        sizes = (int(nlp["x"].numel()), int(nlp["p"].numel()), int(nlp["g"].numel()))
        kind = "generated-stagewise" if stagewise else "generated"
        if plugin == "sqpmethod":  # the edit shapes the library (those built before it reported no failure)
            kind += "-status-" + hashlib.sha256(sqp_edit_text().encode()).hexdigest()[:12]
        if warm:  # the source of the warm start shapes the library too
            kind += "-warm-" + hashlib.sha256((WARM_SOURCE.read_text() + WARM_DUALS).encode()).hexdigest()[:12]
        key = cache_key(plugin, nlp, options, kind=kind)
        loaded = load_cached(name, key, build, lambda library: GeneratedNLP(library, name, *sizes, dual_floor))
        if loaded is not None:
            return loaded
    # Nothing compiled (or every memory of the library in use): the in-process solver, its functions
    # compiled where they can be.
    return compiled_nlpsol(name, plugin, nlp, options)
