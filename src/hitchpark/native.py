"""CasADi functions as native code: generated to C, compiled, cached on disk, called without CasADi's layer.

Below every layer (the plant's step in ``model``, the planner's rollouts and the solvers in
``control`` use it). A CasADi function called from Python costs some 60 us of argument conversion
however little it computes; :class:`CompiledFunction` calls the compiled C through :mod:`ctypes` with
buffers laid out once, a few microseconds. Libraries are kept in a cache folder named by a key of
everything that shapes them, so a process loads in milliseconds what another compiled.

``HITCHPARK_JIT=0`` turns compilation off (a machine without a C compiler falls back by itself):
everything then runs in CasADi's virtual machine, with the same answers to rounding.
``HITCHPARK_CACHE`` moves the cache (default ``$XDG_CACHE_HOME/hitchpark`` or ``~/.cache/hitchpark``).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import threading
import weakref
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

__all__ = [
    "FLAGS",
    "MAX_INSTANCES",
    "SOURCE_FLAGS",
    "CompiledFunction",
    "LibraryCall",
    "build_library",
    "cache_dir",
    "cache_key",
    "cached_library",
    "generated_function",
    "jit_available",
    "load_cached",
    "load_source",
    "lock_file",
    "native",
    "resolved_compiler",
    "resolved_cxx_compiler",
    "source_function",
]

#: Measured on the full OCP: -O1 compiles in ~4.5 s and runs as fast as -O2 (~8 s); -O0 runs 1.5x slower.
#: No fused multiply-add: where the target has it (aarch64, or x86-64 built for a CPU with FMA) a compiler may fuse
#: a * b + c into one rounding, so the same code would answer otherwise on another machine, and otherwise than the
#: exported package (built so too).
FLAGS = ("-O1", "-ffp-contract=off")

#: Compiler flags of hitchpark's own C kernels (:func:`load_source`: the separating lines, the collision checker, the
#: planner's discs): -O2, as the exported package's Makefile builds the lines; -O1 (:data:`FLAGS`) is for the large
#: files CasADi writes, whose compile time it halves. These are small files that compile in a fraction of a second
#: at any level. No level reorders a floating-point operation: the same bits.
SOURCE_FLAGS = ("-O2", "-ffp-contract=off")

#: Callers of one generated library that may live at once in a process (each checks out its own memory).
MAX_INSTANCES = 64

_REAL = ctypes.POINTER(ctypes.c_double)
_INT = ctypes.c_longlong  # casadi_int in the generated code


def resolved_compiler() -> str | None:
    """The C compiler to use (``$CC``, else ``gcc``) as a path, or None if there is none."""
    return _which(os.environ.get("CC", "gcc"))


def resolved_cxx_compiler() -> str | None:
    """The C++ compiler to use (``$CXX``, else ``g++``) as a path, or None if there is none."""
    return _which(os.environ.get("CXX", "g++"))


@functools.lru_cache(maxsize=16)
def _which(name: str) -> str | None:
    return shutil.which(name)


def jit_available() -> bool:
    """Compilation is on (``HITCHPARK_JIT`` is not ``0``) and a C compiler is on the path."""
    return os.environ.get("HITCHPARK_JIT", "1").strip() != "0" and resolved_compiler() is not None


def cache_dir() -> Path:
    """Where compiled code is kept."""
    if os.environ.get("HITCHPARK_CACHE"):
        return Path(os.environ["HITCHPARK_CACHE"]).absolute()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hitchpark"


def cache_key(plugin: str, nlp: Mapping[str, Any], options: Mapping[str, Any], kind: str = "") -> str:
    """A key of everything that shapes a compiled solver: its expression graph, plugin, options, tools."""
    graph = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]).serialize()
    return _key(kind + graph, [plugin, options])


def _key(graph: str, described: Any) -> str:
    """Hash of a serialized graph and what else shapes its build, the tools and where CasADi lives included
    (a generated library links CasADi's own by absolute path)."""
    tools = [ca.CasadiMeta.version(), str(_casadi_home()), resolved_compiler(), FLAGS, MAX_INSTANCES]
    text = json.dumps([described, tools], sort_keys=True, default=repr)
    return hashlib.sha256((graph + text).encode()).hexdigest()[:24]


def _casadi_home() -> Path:
    return Path(ca.__file__).parent


def lock_file(handle: Any) -> None:
    """Hold an exclusive advisory lock on an open file until it is closed (where the system has them)."""
    try:
        import fcntl

        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)  # released when the file is closed
    except (ImportError, OSError):
        pass  # no advisory locks here: at worst two processes compile the same thing


def cached_library(name: str, key: str, build: Callable[[str, Path, Path], bool], rebuild: bool = False) -> Path | None:
    """The library ``name`` of cache entry ``key``, built by ``build(compiler, home, library)`` if missing
    (or, ``rebuild``, replaced: a library that would not load).

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
        if rebuild:
            library.unlink(missing_ok=True)
        if not library.is_file() and not build(compiler, home, library):
            return None
    return library


def load_cached(name: str, key: str, build: Callable[[str, Path, Path], bool], load: Callable[[Path], Any]) -> Any:
    """``load(library)`` of :func:`cached_library`, rebuilt once if it would not load; None if none loads."""
    for rebuild in (False, True):
        library = cached_library(name, key, build, rebuild)
        if library is None:
            return None
        try:
            return load(library)
        except (OSError, AttributeError):  # cut short, or of another build: compile it again
            continue
    return None


def build_library(
    function: Any,
    links: Sequence[str],
    compiler: str,
    home: Path,
    library: Path,
    extra: Sequence[Any] = (),
    edit: Callable[[str], str | None] | None = None,
    cxx: Path | None = None,
) -> bool:
    """Generate the C of a CasADi ``function`` and compile it into ``library`` (atomically); False if refused.

    ``links``: libraries of CasADi's package the code calls into (a solver's, say). ``edit`` rewrites the C
    of ``function``, or returns None, and then the library is built from it unedited and without ``extra``:
    more CasADi functions compiled into the same library (their own C file), which the edit links in.
    ``cxx``: a C++ source compiled (C++17, against CasADi's headers) and linked into the library, its
    definitions binding the library's own calls (``-Bsymbolic``); False if it does not compile.
    """
    casadi_home = _casadi_home()
    with tempfile.TemporaryDirectory(dir=home) as scratch:
        source = Path(scratch) / f"{library.stem}.c"
        sources = [source]
        here = os.getcwd()
        try:
            os.chdir(scratch)  # CasADi writes the files into the working folder
            function.generate(source.name, {"main": False, "with_header": False})
            edited = edit(source.read_text()) if edit is not None else None
            if edited is not None:
                source.write_text(edited)
                if extra:
                    more = ca.CodeGenerator(f"{library.stem}_more.c", {"main": False, "with_header": False})
                    for f in extra:
                        more.add(f)
                    more.generate()
                    sources.append(Path(scratch) / f"{library.stem}_more.c")
        except RuntimeError:
            return False
        finally:
            os.chdir(here)
        objects: list[str] = []
        if cxx is not None:
            cxx_compiler = resolved_cxx_compiler()
            if cxx_compiler is None:
                return False
            obj = Path(scratch) / f"{cxx.stem}.o"
            flags = [*FLAGS, "-std=c++17", "-fPIC", "-c", str(cxx), f"-I{casadi_home / 'include'}", "-o", str(obj)]
            done = subprocess.run([cxx_compiler, *flags], capture_output=True, text=True, check=False)
            if done.returncode != 0 or not obj.is_file():
                return False
            objects = [str(obj), "-lstdc++", "-Wl,-Bsymbolic"]
        built = Path(scratch) / library.name
        command = [
            compiler,
            *FLAGS,
            f"-DCASADI_MAX_NUM_THREADS={MAX_INSTANCES}",
            "-fPIC",
            "-shared",
            *map(str, sources),
            *objects,
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


def load_source(name: str, source: Path, load: Callable[[Path], Any], includes: Sequence[Path] = ()) -> Any:
    """``load(library)`` of the plain C file ``source`` compiled into the cache (keyed by its text, the texts of
    the files it ``includes`` and the tools), as :func:`load_cached`: None where nothing compiles or loads. No
    multiply-add is fused (as compilers may where the processor has the instruction), so the C rounds as NumPy
    does."""
    text = "".join(path.read_text() for path in (source, *includes))

    def build(compiler: str, home: Path, library: Path) -> bool:
        with tempfile.TemporaryDirectory(dir=home) as scratch:
            built = Path(scratch) / library.name
            flags = [*SOURCE_FLAGS, "-fPIC", "-shared"]
            command = [compiler, *flags, str(source), "-lm", "-o", str(built)]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            if done.returncode != 0 or not built.is_file():
                return False
            os.replace(built, library)
        return True

    return load_cached(name, _key(text, ["source", name, *SOURCE_FLAGS]), build, load)


def source_function(
    name: str, source: Path, symbol: str, argtypes: Sequence[Any], includes: Sequence[Path] = ()
) -> Any:
    """The C function ``symbol`` (returning an ``int``) of the plain C file ``source`` (which includes the
    files ``includes`` beside it), compiled and loaded as :func:`load_source` does, with its argument types set:
    None where nothing compiles or loads."""

    def load(library: Path) -> Any:
        function = getattr(ctypes.CDLL(str(library)), symbol)
        function.restype = ctypes.c_int
        function.argtypes = list(argtypes)
        return function

    return load_source(name, source, load, includes)


class LibraryCall:
    """The generated function ``name`` of ``library``, its dense inputs and outputs as NumPy buffers.

    Fill :attr:`inputs`, :meth:`call`, read :attr:`outputs` (flat, column-major as CasADi lays them).
    """

    def __init__(self, library: Path, name: str, in_sizes: Sequence[int], out_sizes: Sequence[int]):
        #: The loaded library (its other exported functions, if any, are reached through it).
        self.library = ctypes.CDLL(str(library))
        self._call = getattr(self.library, name)
        self._call.restype = ctypes.c_int
        sizes = [_INT() for _ in range(4)]
        getattr(self.library, f"{name}_work")(*[ctypes.byref(s) for s in sizes])
        n_arg, n_res, n_iw, n_w = (s.value for s in sizes)
        checkout = getattr(self.library, f"{name}_checkout")
        checkout.restype = ctypes.c_int
        self._mem = checkout()
        if self._mem < 0:
            raise OSError(f"all {MAX_INSTANCES} memories of {library.name} are in use")
        weakref.finalize(self, getattr(self.library, f"{name}_release"), self._mem)
        self.inputs = [np.zeros(n) for n in in_sizes]
        self.outputs = [np.zeros(n) for n in out_sizes]
        self._arg = (_REAL * n_arg)(*[a.ctypes.data_as(_REAL) for a in self.inputs])  # the rest: NULL
        self._res = (_REAL * n_res)(*[a.ctypes.data_as(_REAL) for a in self.outputs])
        self._iw = np.zeros(max(n_iw, 1), dtype=np.int64)
        self._w = np.zeros(max(n_w, 1))
        self._iw_p = self._iw.ctypes.data_as(ctypes.POINTER(_INT))
        self._w_p = self._w.ctypes.data_as(_REAL)
        #: Hold it while filling the buffers, calling and copying the answer out: ctypes lets other
        #: threads run during the call, and they share these buffers.
        self.lock = threading.Lock()

    def call(self) -> int:
        """Run it on :attr:`inputs`; the generated code's return value (nonzero: it failed)."""
        return int(self._call(self._arg, self._res, self._iw_p, self._w_p, self._mem))


class CompiledFunction:
    """A CasADi function compiled to C, called like it with NumPy arguments: ``f(a, b) -> array``.

    Each argument is a number (filling the input) or an array of the input's shape (a vector input
    also takes a flat array of its length). Returns the output as a 2-D array, or a tuple of them.
    """

    def __init__(self, library: Path, function: ca.Function):
        self._shapes_in = [function.size_in(i) for i in range(function.n_in())]
        self._shapes_out = [function.size_out(i) for i in range(function.n_out())]
        self._lib = LibraryCall(
            library,
            function.name(),
            [r * c for r, c in self._shapes_in],
            [r * c for r, c in self._shapes_out],
        )
        self._name = function.name()
        self._source = (library, function)

    def __reduce__(self) -> tuple[Any, ...]:
        return (CompiledFunction, self._source)  # another process loads the library anew

    def name(self) -> str:
        return self._name

    def __repr__(self) -> str:
        return f"CompiledFunction({self._name})"

    def __call__(self, *args: Any) -> Any:
        if len(args) != len(self._shapes_in):
            raise TypeError(f"{self._name} takes {len(self._shapes_in)} arguments, got {len(args)}")
        values = [np.asarray(value, dtype=float) for value in args]
        for a, (rows, cols) in zip(values, self._shapes_in, strict=True):
            vector = 1 in (rows, cols) and a.size == rows * cols  # the same numbers in either order
            if not (a.ndim == 0 or vector or a.shape == (rows, cols)):
                raise ValueError(f"{self._name}: an argument of shape {a.shape}, expected {(rows, cols)}")
        with self._lib.lock:
            for a, buffer in zip(values, self._lib.inputs, strict=True):
                buffer[:] = a.ravel(order="F")  # a number fills the input; CasADi's matrices are column-major
            if self._lib.call():
                raise RuntimeError(f"{self._name}: the compiled function failed")
            out = tuple(b.reshape(c, r).T.copy() for b, (r, c) in zip(self._lib.outputs, self._shapes_out, strict=True))
        return out[0] if len(out) == 1 else out


def generated_function(function: ca.Function) -> ca.Function | CompiledFunction:
    """``function`` compiled to C where it can be (:class:`CompiledFunction`), else itself.

    Only functions of dense inputs and outputs are compiled: they are what is called in loops.
    """
    dense = all(function.sparsity_in(i).is_dense() for i in range(function.n_in())) and all(
        function.sparsity_out(i).is_dense() for i in range(function.n_out())
    )
    if not dense:
        return function
    loaded = load_cached(
        function.name(),
        _key(function.serialize(), "function"),
        lambda cc, home, lib: build_library(function, (), cc, home, lib),
        lambda library: CompiledFunction(library, function),
    )
    return function if loaded is None else loaded


def native(function: ca.Function) -> ca.Function | CompiledFunction:
    """:func:`generated_function` of ``function``, once per process (and per ``HITCHPARK_JIT``)."""
    return _native(function, jit_available())


@functools.lru_cache(maxsize=256)
def _native(function: ca.Function, compiling: bool) -> ca.Function | CompiledFunction:
    return generated_function(function) if compiling else function
