"""NLP solvers whose functions are compiled to C (CasADi ``jit``), cached on disk.

CasADi evaluates the NLP's functions (cost, constraints, their Jacobian and the Lagrangian's
Hessian) in its virtual machine by default. Compiled with the system's C compiler they run
several times faster; for the full-model OCP this halves the whole solve (docs/performance.md).
Compiling takes seconds, so the built solver and its shared library are kept in a cache folder
named by a key of everything that shapes them (the NLP's expression graph, the plugin and its
options, the CasADi version, the compiler and its flags), and the next process loads them in
milliseconds.

``HITCHPARK_JIT=0`` turns compilation off (a machine without a C compiler falls back by
itself); ``HITCHPARK_CACHE`` moves the cache (default ``$XDG_CACHE_HOME/hitchpark`` or
``~/.cache/hitchpark``). A cache that cannot be written costs only the compile next time.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import casadi as ca

from ..native import FLAGS, cache_dir, cache_key, jit_available, lock_file, resolved_compiler

__all__ = ["cache_dir", "compiled_nlpsol", "jit_available", "resolved_compiler"]


def compiled_nlpsol(name: str, plugin: str, nlp: Mapping[str, Any], options: Mapping[str, Any]) -> Any:
    """``casadi.nlpsol(name, plugin, nlp, options)`` with compiled functions, from the cache when it can.

    Falls back to the uncompiled solver when no compiler is available or compiling fails.
    """
    compiler = resolved_compiler()
    if compiler is None or not jit_available():
        return ca.nlpsol(name, plugin, dict(nlp), dict(options))
    home = cache_dir() / f"{name}-{cache_key(plugin, nlp, options)}"
    try:
        home.mkdir(parents=True, exist_ok=True)
        lock = open(home / ".lock", "a")
    except OSError:  # no cache to be had: the library would have nowhere to live
        return ca.nlpsol(name, plugin, dict(nlp), dict(options))
    with lock:
        # One process compiles, the others of a pool wait here and then load what it saved.
        lock_file(lock)
        solver = _load(home / "solver.casadi")
        if solver is None:
            solver = _compile(name, plugin, nlp, options, compiler, home)
            if solver is not None:
                _save(solver, home / "solver.casadi")
    return solver if solver is not None else ca.nlpsol(name, plugin, dict(nlp), dict(options))


def _load(path: Path) -> Any:
    if not path.is_file():
        return None
    try:
        return ca.Function.load(str(path))
    except RuntimeError:
        return None  # a file cut short, or its library gone: compile anew and replace it


def _compile(
    name: str, plugin: str, nlp: Mapping[str, Any], options: Mapping[str, Any], compiler: str, home: Path
) -> Any:
    """The solver with its functions compiled into a library in ``home``; None if the compiler refused."""
    jit: dict[str, Any] = {
        "jit": True,
        "compiler": "shell",
        "jit_name": name,
        "jit_temp_suffix": True,
        "jit_cleanup": False,  # the C source is removed here, right after compiling
        "jit_serialize": "link",  # the saved solver loads the library kept beside it
        "jit_options": {"compiler": compiler, "flags": list(FLAGS), "directory": str(home) + os.sep, "cleanup": False},
    }
    # CasADi writes the generated C into the working folder: make that the cache entry, never the user's folder.
    here = os.getcwd()
    before = set(home.iterdir())
    try:
        os.chdir(home)
        solver = ca.nlpsol(name, plugin, dict(nlp), {**options, **jit})
    except RuntimeError:  # the compiler refused: the caller runs uncompiled rather than not at all
        return None
    finally:
        os.chdir(here)
        for scrap in set(home.iterdir()) - before:
            if scrap.suffix in (".c", ".o"):
                scrap.unlink(missing_ok=True)
    return solver


def _save(solver: Any, path: Path) -> None:
    """Write atomically: a reader sees the whole file or none."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".part-", dir=path.parent)
        os.close(fd)
        try:
            solver.save(tmp)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except (OSError, RuntimeError):
        pass  # an unwritable cache only means compiling again next time
