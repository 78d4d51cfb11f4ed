"""A package exported once per session and its library built once: the tests of ``hitchpark export`` and ``sil``."""

from __future__ import annotations

import fcntl
import json
import os
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import pytest
from flags import WARNINGS

from hitchpark.app.export import ExportSpec, library_sources, package_files
from hitchpark.app.export_folder import copy_package
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.native import resolved_compiler


def compiler_or_skip() -> str:
    compiler = resolved_compiler()
    if compiler is None:
        pytest.skip("no C compiler on this machine ($CC, else gcc): the exported package is not built")
    return compiler


@pytest.fixture(scope="session")
def c_compiler() -> str:
    """The system's C compiler (the test skips, saying so, where there is none)."""
    return compiler_or_skip()


@pytest.fixture(scope="session")
def random_spec() -> ExportSpec:
    """The package of the default full-model NMPC with its obstacle OCP (every file a package can have), its example
    from the paper's random scenario (ideal plant)."""
    sc = builtin_scenario("random")
    return ExportSpec(sc.vehicle, start=sc.start, goal=sc.goal, plant=sc.plant, scenario=sc.name, obstacles=True)


@pytest.fixture(scope="session")
def random_files(random_spec: ExportSpec) -> dict[str, str]:
    return package_files(random_spec)


@pytest.fixture(scope="session")
def open_space_files(random_spec: ExportSpec) -> dict[str, str]:
    """The package without the obstacle OCP (what ``hitchpark export`` writes by default)."""
    return package_files(replace(random_spec, obstacles=False))


@dataclass(frozen=True)
class Built:
    """The package compiled once a session with the system's compiler: each library file's object (position
    independent: for the shared library and for programs alike), what the compiler said, the shared library (as
    ``hitchpark sil`` builds it) and the example."""

    folder: Path
    objects: tuple[Path, ...]
    stderr: str
    library: Path
    example: Path


@pytest.fixture(scope="session")
def built(random_files: dict[str, str], tmp_path_factory: pytest.TempPathFactory) -> Built:
    """Built once for the whole run: under pytest-xdist the workers share the run's temporary root, and the first
    builds while the others wait on a lock (fcntl) and reuse it."""
    compiler = compiler_or_skip()
    root = tmp_path_factory.getbasetemp()
    shared = root.parent if os.environ.get("PYTEST_XDIST_WORKER") else root
    with open(shared / "export-built.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            return _built(random_files, shared / "export-built", compiler)
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _built(random_files: dict[str, str], home: Path, compiler: str) -> Built:
    folder = home / "pkg"
    record_file = home / "built.json"
    if record_file.is_file():  # another worker built it
        record = json.loads(record_file.read_text())
        return Built(folder, tuple(Path(p) for p in record["objects"]), record["stderr"], folder / record["library"],
                     folder / record["example"])  # fmt: skip
    copy_package(random_files, folder)
    flags = [*WARNINGS, "-fPIC", f"-I{folder / 'include'}"]
    jobs = []
    for name in library_sources(random_files):  # all at once: the machine's cores share them
        obj = folder / (Path(name).stem + ".o")
        command = [compiler, *flags, "-c", str(folder / name), "-o", str(obj)]
        jobs.append((obj, subprocess.Popen(command, stderr=subprocess.PIPE, text=True)))
    said = [job.communicate()[1] for _, job in jobs]
    assert all(job.returncode == 0 for _, job in jobs), "".join(said)
    objects = tuple(obj for obj, _ in jobs)
    library, example = folder / "libhitchpark_nmpc.so", folder / "example"
    for command in (
        [compiler, "-shared", *map(str, objects), "-lm", "-o", str(library)],
        [compiler, *flags, str(folder / "examples" / "main.c"), str(folder / "examples" / "example_plant.c"),
         *map(str, objects), "-lm", "-o", str(example)],
    ):  # fmt: skip
        done = subprocess.run(command, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        said.append(done.stderr)
    record = {"objects": [str(p) for p in objects], "stderr": "".join(said), "library": library.name,
              "example": example.name}  # fmt: skip
    record_file.write_text(json.dumps(record))
    return Built(folder, objects, record["stderr"], library, example)


@pytest.fixture(scope="session")
def library(built: Built) -> Path:
    """The package's shared library, built as ``hitchpark sil`` builds it."""
    return built.library


@pytest.fixture(scope="module")
def compiled_in_process(_run_cache: Path) -> Iterator[Path]:
    """Compilation on for the in-process controller (its riccati_c) while the module runs, into the run's one cache
    (compiled once, loaded by the next module and by the solver tests)."""
    compiler_or_skip()
    cache = _run_cache
    saved = {k: os.environ.get(k) for k in ("HITCHPARK_JIT", "HITCHPARK_CACHE")}
    os.environ["HITCHPARK_JIT"], os.environ["HITCHPARK_CACHE"] = "1", str(cache)
    try:
        yield cache
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
