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

import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from ..native import LibraryCall, build_library, cache_key, load_cached, resolved_compiler
from .compiled import compiled_nlpsol

__all__ = ["GeneratedNLP", "generated_nlpsol"]

#: Libraries the generated code of a plugin calls into (they ship inside CasADi's Python package).
_LINKED = {"fatrop": ("fatrop", "blasfeo"), "sqpmethod": ()}


class GeneratedNLP:
    """A compiled solver with the calling convention of a CasADi ``nlpsol``: ``solver(x0=, p=, lbx=, ...)``.

    Returns ``{"x", "f", "g", "lam_x", "lam_g"}`` (NumPy arrays, ``f`` a number); :meth:`stats` says whether
    the last call succeeded (the generated code returns nonzero when the solver did not converge).
    """

    _INPUTS = ("x0", "p", "lbx", "ubx", "lbg", "ubg", "lam_x0", "lam_g0")
    _OUTPUTS = ("x", "f", "g", "lam_x", "lam_g")

    def __init__(self, library: Path, name: str, n_x: int, n_p: int, n_g: int):
        self._lib = LibraryCall(library, name, (n_x, n_p, n_x, n_x, n_g, n_g, n_x, n_g), (n_x, 1, n_g, n_x, n_g))
        self._code = 0
        self._source = (library, name, n_x, n_p, n_g)

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
            self._code = self._lib.call()
            out: dict[str, Any] = {k: v.copy() for k, v in zip(self._OUTPUTS, self._lib.outputs, strict=True)}
        out["f"] = float(out["f"][0])  # a number, as CasADi's 1x1 answer converts to one
        return out

    def stats(self) -> dict[str, Any]:
        ok = self._code == 0
        return {"success": ok, "return_status": "Solve_Succeeded" if ok else f"not converged (code {self._code})"}


#: A stage-wise function called by the generated solver: its own argument lists and work arrays (of the
#: sizes it asks for; one set per thread), whatever the solver's oracle allots to the function it replaces.
_CALLBACK = """
int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem);
static int {name}_cb(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{
  static _Thread_local const casadi_real* a[{sz_arg}];
  static _Thread_local casadi_real* r[{sz_res}];
  static _Thread_local casadi_int iw_[{sz_iw}];
  static _Thread_local casadi_real w_[{sz_w}];
  int i;
  for (i = 0; i < {n_in}; ++i) a[i] = arg[i];
  for (i = 0; i < {n_out}; ++i) r[i] = res[i];
  return {name}(a, r, iw_, w_, 0);
}}
"""


def _link_stagewise(source: str, functions: Mapping[str, ca.Function]) -> str | None:
    """The C of a generated fatrop solver calling ``functions`` (:mod:`.stagewise`) instead of CasADi's.

    The solver's oracle takes each function as a pointer (``p.nlp_hess_l.eval = casadi_f6;``), and the
    gradient it reports at the end is one direct call; each is pointed at a callback of the stage-wise
    function. None when the code is not laid out so (another CasADi): then the solver stays as generated.
    """
    edited, callbacks = source, []
    for key, f in functions.items():
        name = f.name()
        callbacks.append(
            _CALLBACK.format(
                name=name,
                sz_arg=max(f.sz_arg(), 1),
                sz_res=max(f.sz_res(), 1),
                sz_iw=max(f.sz_iw(), 1),
                sz_w=max(f.sz_w(), 1),
                n_in=f.n_in(),
                n_out=f.n_out(),
            )
        )
        if key == "nlp_grad":  # called once, after the iterations: f, g and the gradient in p
            found = re.findall(r"/\* nlp_grad:\(.*\*/\nstatic int (casadi_f\d+)\(", edited)
            if len(found) != 1:
                return None
            call = f"if ({found[0]}(d->arg, d->res, d->iw, d->w, 0)) return 1;"
            if edited.count(call) != 1:
                return None
            edited = edited.replace(call, f"if ({name}_cb(d->arg, d->res, d->iw, d->w, 0)) return 1;")
        else:
            found = re.findall(rf"p\.{key}\.eval = (casadi_f\d+);", edited)
            if len(found) != 1:
                return None
            edited = edited.replace(f"p.{key}.eval = {found[0]};", f"p.{key}.eval = {name}_cb;")
    anchor = "static int casadi_f0(const casadi_real** arg"
    if edited.count(anchor) != 1:
        return None
    return edited.replace(anchor, "".join(callbacks) + "\n" + anchor)


def generated_nlpsol(
    name: str,
    plugin: str,
    nlp: Mapping[str, Any],
    options: Mapping[str, Any],
    stages: Callable[[ca.Function, str], Mapping[str, ca.Function] | None] | None = None,
) -> Any:
    """The solver ``casadi.nlpsol(name, plugin, nlp, options)`` as compiled C, from the cache when it can.

    ``stages(solver, prefix)``: the NLP's functions stage by stage (:func:`.stagewise.stagewise_functions`
    of the transcription), which fatrop's generated code then calls in place of CasADi's: code the size of
    a stage instead of the horizon's, the same numbers. Falls back to the in-process CasADi solver (the same
    plugin and options) where nothing can be compiled.
    """
    compiler = resolved_compiler()
    stagewise = stages is not None and plugin == "fatrop"
    if compiler is not None and plugin in _LINKED:

        def build(compiler: str, home: Path, library: Path) -> bool:
            # error_on_fail: the generated function returns nonzero when the solver did not converge.
            solver = ca.nlpsol(name, plugin, dict(nlp), {**options, "error_on_fail": True})
            functions = stages(solver, f"{name}_stage_") if stages is not None and stagewise else None
            if not functions:
                return build_library(solver, _LINKED[plugin], compiler, home, library)
            return build_library(
                solver,
                _LINKED[plugin],
                compiler,
                home,
                library,
                extra=list(functions.values()),
                edit=lambda source: _link_stagewise(source, functions),
            )

        sizes = (int(nlp["x"].numel()), int(nlp["p"].numel()), int(nlp["g"].numel()))
        key = cache_key(plugin, nlp, options, kind="generated-stagewise" if stagewise else "generated")
        loaded = load_cached(name, key, build, lambda library: GeneratedNLP(library, name, *sizes))
        if loaded is not None:
            return loaded
    # Nothing compiled (or every memory of the library in use): the in-process solver, its functions
    # compiled where they can be.
    return compiled_nlpsol(name, plugin, nlp, options)
