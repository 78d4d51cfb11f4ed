"""Whole NLP solvers generated to C by CasADi, compiled, and called without CasADi's Python layer.

:mod:`.compiled` compiles the NLP's functions and leaves the solver in CasADi's virtual machine;
here CasADi writes the solver itself (fatrop's or sqpmethod's iterations, the QP, the functions)
as one C file, the system's C compiler makes a shared library of it, and each call fills
buffers laid out once and calls the library through :mod:`ctypes`. On the paper's OCP a call
costs about a tenth of a millisecond less than the same solver called through CasADi
(``hitchpark bench``); on an embedded computer this C file is what would run.

The library is kept in the cache of :mod:`.compiled` under a key of everything that shapes it.
Where nothing can be compiled (``HITCHPARK_JIT=0``, no C compiler, a compiler that refuses),
:func:`generated_nlpsol` returns the same plugin with the same options in-process: the same
answers to rounding, only slower.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import subprocess
import tempfile
import weakref
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from .compiled import FLAGS, cache_dir, cache_key, jit_available, lock_file, resolved_compiler

__all__ = ["GeneratedNLP", "generated_function", "generated_nlpsol"]

#: Libraries the generated code of a plugin calls into (they ship inside CasADi's Python package).
_LINKED = {"fatrop": ("fatrop", "blasfeo"), "sqpmethod": ()}

#: Solvers of one library that may live at once in a process (each checks out its own memory).
MAX_INSTANCES = 64

_REAL = ctypes.POINTER(ctypes.c_double)
_INT = ctypes.c_longlong  # casadi_int in the generated code


def _casadi_home() -> Path:
    return Path(ca.__file__).parent


class GeneratedNLP:
    """A compiled solver with the calling convention of a CasADi ``nlpsol``: ``solver(x0=, p=, lbx=, ...)``.

    Returns ``{"x", "f", "g", "lam_x", "lam_g"}`` as NumPy arrays; :meth:`stats` says whether the last
    call succeeded (the generated code returns nonzero when the solver did not converge) and how.
    """

    _INPUTS = ("x0", "p", "lbx", "ubx", "lbg", "ubg", "lam_x0", "lam_g0")

    def __init__(self, library: Path, name: str, n_x: int, n_p: int, n_g: int):
        self._lib = ctypes.CDLL(str(library))
        self._call = getattr(self._lib, name)
        self._call.restype = ctypes.c_int
        sizes = [_INT() for _ in range(4)]
        getattr(self._lib, f"{name}_work")(*[ctypes.byref(s) for s in sizes])
        n_arg, n_res, n_iw, n_w = (s.value for s in sizes)
        checkout = getattr(self._lib, f"{name}_checkout")
        checkout.restype = ctypes.c_int
        self._mem = checkout()
        if self._mem < 0:
            raise OSError(f"all {MAX_INSTANCES} solver memories of {library.name} are in use")
        release = getattr(self._lib, f"{name}_release")
        weakref.finalize(self, release, self._mem)
        self._in = [np.zeros(n) for n in (n_x, n_p, n_x, n_x, n_g, n_g, n_x, n_g)]
        self._out = {key: np.zeros(n) for key, n in (("x", n_x), ("f", 1), ("g", n_g), ("lam_x", n_x), ("lam_g", n_g))}
        self._arg = (_REAL * n_arg)(*[a.ctypes.data_as(_REAL) for a in self._in])  # the rest: NULL
        self._res = (_REAL * n_res)(*[a.ctypes.data_as(_REAL) for a in self._out.values()])
        self._iw = np.zeros(max(n_iw, 1), dtype=np.int64)
        self._w = np.zeros(max(n_w, 1))
        self._iw_p = self._iw.ctypes.data_as(ctypes.POINTER(_INT))
        self._w_p = self._w.ctypes.data_as(_REAL)
        self._code = 0

    def __call__(self, **inputs: Any) -> dict[str, Any]:
        unknown = set(inputs) - set(self._INPUTS)
        if unknown:
            raise RuntimeError(f"unknown solver inputs {sorted(unknown)}; allowed: {', '.join(self._INPUTS)}")
        for key, buffer in zip(self._INPUTS, self._in, strict=True):
            value = inputs.get(key)
            if value is None:  # CasADi's defaults: free bounds, zero guesses and multipliers
                buffer[:] = -np.inf if key in ("lbx", "lbg") else np.inf if key in ("ubx", "ubg") else 0.0
            else:
                buffer[:] = np.asarray(value, dtype=float).ravel()
        self._code = int(self._call(self._arg, self._res, self._iw_p, self._w_p, self._mem))
        out: dict[str, Any] = {key: value.copy() for key, value in self._out.items()}
        out["f"] = float(out["f"][0])  # a number, as CasADi's 1x1 answer converts to one
        return out

    def stats(self) -> dict[str, Any]:
        ok = self._code == 0
        return {"success": ok, "return_status": "Solve_Succeeded" if ok else f"not converged (code {self._code})"}


def _cached_library(name: str, key: str, build: Callable[[str, Path, Path], bool]) -> Path | None:
    """The library ``name`` of cache entry ``key``, built by ``build(compiler, home, library)`` if missing.

    None where nothing can be compiled (switched off, no compiler, no cache, a refusal).
    """
    compiler = resolved_compiler()
    if compiler is None or not jit_available():
        return None
    home = cache_dir() / f"{name}-c-{key}"
    library = home / f"{name}.so"
    try:
        home.mkdir(parents=True, exist_ok=True)
        lock = open(home / ".lock", "a")
    except OSError:
        return None
    with lock:
        lock_file(lock)  # one process of a pool compiles, the others wait and load it
        if not library.is_file() and not build(compiler, home, library):
            return None
    return library


def generated_nlpsol(name: str, plugin: str, nlp: Mapping[str, Any], options: Mapping[str, Any]) -> Any:
    """The solver ``casadi.nlpsol(name, plugin, nlp, options)`` as compiled C, from the cache when it can.

    Falls back to the in-process CasADi solver (the same plugin and options) where nothing can be
    compiled.
    """
    compiler = resolved_compiler()
    library = None
    if compiler is not None and plugin in _LINKED:
        key = cache_key(plugin, nlp, options, compiler, kind=f"generated-{MAX_INSTANCES}")

        def build(compiler: str, home: Path, library: Path) -> bool:
            # error_on_fail: the generated function returns nonzero when the solver did not converge.
            solver = ca.nlpsol(name, plugin, dict(nlp), {**options, "error_on_fail": True})
            return _build(solver, _LINKED[plugin], compiler, home, library)

        library = _cached_library(name, key, build)
    if library is not None:
        sizes = (int(nlp["x"].numel()), int(nlp["p"].numel()), int(nlp["g"].numel()))
        try:
            return GeneratedNLP(library, name, *sizes)
        except (OSError, AttributeError):  # a library cut short or of another build: run in-process
            pass
    return ca.nlpsol(name, plugin, dict(nlp), dict(options))


def generated_function(function: ca.Function) -> ca.Function:
    """``function`` as compiled C (loaded with ``casadi.external``), or itself where nothing compiles.

    For the functions called many times from Python with real work inside (the planner's batches of
    rollouts): the same answers, about half the time.
    """
    compiler = resolved_compiler()
    if compiler is None:
        return function
    name = function.name()
    described = json.dumps([ca.CasadiMeta.version(), compiler, FLAGS])
    key = hashlib.sha256((function.serialize() + described).encode()).hexdigest()[:24]
    library = _cached_library(name, key, lambda cc, home, lib: _build(function, (), cc, home, lib))
    if library is None:
        return function
    try:
        return ca.external(name, str(library))
    except RuntimeError:
        return function


def _build(function: Any, links: tuple[str, ...], compiler: str, home: Path, library: Path) -> bool:
    """Generate the C of ``function`` and compile it into ``library`` (written atomically); False if refused."""
    name = library.stem
    casadi_home = _casadi_home()
    with tempfile.TemporaryDirectory(dir=home) as scratch:
        source = Path(scratch) / f"{name}.c"
        here = os.getcwd()
        try:
            os.chdir(scratch)  # CasADi writes the file into the working folder
            function.generate(source.name, {"main": False, "with_header": False})
        except RuntimeError:
            return False
        finally:
            os.chdir(here)
        built = Path(scratch) / library.name
        command = [
            compiler,
            *FLAGS,
            f"-DCASADI_MAX_NUM_THREADS={MAX_INSTANCES}",
            "-fPIC",
            "-shared",
            str(source),
            f"-I{casadi_home / 'include'}",
            f"-L{casadi_home}",
            f"-Wl,-rpath,{casadi_home}",
            *[f"-l{lib}" for lib in links],
            "-lm",
            "-o",
            str(built),
        ]
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0 or not built.is_file():
            return False
        os.replace(built, library)
    return True
