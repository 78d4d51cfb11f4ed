"""``hitchpark export``'s package: its files, a static check of its C, builds with gcc and clang, the C API's answers
to bad input, two controllers side by side, and the example against ``park``."""

from __future__ import annotations

import ctypes
import hashlib
import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from flags import WARNINGS

from hitchpark.app.export import PACKAGE_FILES, ExportSpec, package_files
from hitchpark.app.export_folder import copy_package
from hitchpark.app.exported import ExportedNMPC, _Command, _Measurement, _Pose, _Status
from hitchpark.app.sil import sil_settings
from hitchpark.app.sweep import load_settings
from hitchpark.control import make_nmpc
from hitchpark.maneuver.process import park
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model.plant import Command, Measurement
from hitchpark.model.scene import Obstacle, Scene
from hitchpark.model.state import Pose, State
from hitchpark.ocp.reference import PathReference
from hitchpark.solvers.riccati import riccati_source


def test_the_package_holds_its_files_and_a_manifest_of_them(random_files):
    assert sorted(random_files) == sorted(PACKAGE_FILES)
    manifest = json.loads(random_files["manifest.json"])
    assert manifest["format"] == "hitchpark-export/2"
    assert manifest["settings"]["nmpc"]["kind"] == "full"
    for name, digest in manifest["sha256"].items():
        assert hashlib.sha256(random_files[name].encode()).hexdigest() == digest
    # the solver is the in-process route's own file, byte for byte
    assert random_files["src/riccati_ipm.inc"] == riccati_source()
    assert (
        f"#define HITCHPARK_NMPC_WORKSPACE_BYTES {manifest['workspace_bytes']}"
        in random_files["include/hitchpark_nmpc.h"]
    )


def _code(text: str) -> str:
    """C without its comments and string literals."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    return re.sub(r'"(\\.|[^"\\])*"', '""', text)


def test_the_sources_allocate_nothing_print_nothing_and_keep_no_mutable_state(random_files):
    sources = {k: v for k, v in random_files.items() if k.startswith(("src/", "include/"))}
    forbidden = re.compile(r"\b(malloc|calloc|realloc|free|printf|fprintf|puts|fopen|fwrite|exit|abort)\s*\(")
    for name, text in sources.items():
        code = _code(text)
        assert not forbidden.search(code), (name, forbidden.search(code))
        assert "<stdio.h>" not in code and "<stdlib.h>" not in code, name
        assert "_Thread_local" not in code and "thread_local" not in code, name
        # a file-scope (or function-scope) static that is not const: a variable, where a function has '('
        for line in code.splitlines():
            stripped = line.strip()
            if stripped.startswith("static ") and "const" not in stripped.split("=")[0]:
                assert "(" in stripped.split("=")[0], (name, stripped)


def _build(compiler: str, folder: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    sources = sorted((folder / "src").glob("*.c"))  # the library's (export.library_sources)
    example = [folder / "examples" / "main.c", folder / "examples" / "example_plant.c"]
    command = [compiler, *WARNINGS, *extra, f"-I{folder / 'include'}", *map(str, sources + example)]
    return subprocess.run([*command, "-lm", "-o", str(folder / "example")], capture_output=True, text=True)


@pytest.mark.slow
def test_the_package_builds_without_a_warning_by_the_system_compiler(built):
    """The package (every OCP and the geometry) compiled with -Wall -Wextra -pedantic -Werror, linked as a library and
    as the example: the compiler says nothing."""
    assert not built.stderr.strip(), built.stderr


@pytest.mark.slow
def test_the_package_builds_without_a_warning_by_clang(random_files, tmp_path):
    compiler = shutil.which("clang")
    if compiler is None:
        pytest.skip("no clang on this machine")
    copy_package(random_files, tmp_path / "pkg")
    done = _build(compiler, tmp_path / "pkg", "-O0")  # clang warns in its front end, whatever the optimisation
    assert done.returncode == 0 and not done.stderr.strip(), done.stderr


def _api(library: Path):
    sc = builtin_scenario("random")
    nmpc = ExportedNMPC(library, sc.vehicle, sil_settings(sc.settings).nmpc)
    return nmpc, nmpc._lib


def _step(lib, handle, m, in_flight=(), g=None):
    g = g or _Pose(0.0, 0.0, 0.0)
    commands = (_Command * max(1, len(in_flight)))(*in_flight)
    out, status = _Command(), _Status()
    code = lib.hitchpark_nmpc_step(handle, m, g, commands, len(in_flight), out, ctypes.byref(status))
    return code, (out.rear_speed, out.front_steer), status


def test_bad_input_gives_its_error_code_and_a_stop_and_leaves_the_workspace_sound(library):
    nmpc, lib = _api(library)
    good = _Measurement(8.0, 1.0, 0.2, 0.1, 0.05, 0.0)
    code, first, status = _step(lib, nmpc._handle, good)
    assert code == 0 and status.ok and status.converged and status.iterations > 0 and status.solve_time_ns > 0
    held = first[1]
    cases = {
        3: _Measurement(math.nan, 1.0, 0.2, 0.1, 0.05, 0.0),  # NaN measurement
        4: _Measurement(8.0, 1.0, 0.2, 1.5, 0.05, 0.0),  # the hitch past max_hitch
    }
    for expected, m in cases.items():
        code, command, status = _step(lib, nmpc._handle, m)
        assert code == expected == status.error and not status.ok and status.stop
        assert command == (0.0, held)  # a stop, the wheels held
        assert status.message
    out, status = _Command(), _Status()
    assert lib.hitchpark_nmpc_step(nmpc._handle, None, _Pose(), None, 0, out, ctypes.byref(status)) == 1
    assert (out.rear_speed, out.front_steer) == (0.0, held)
    assert lib.hitchpark_nmpc_step(None, good, _Pose(), None, 0, out, ctypes.byref(status)) == 1
    assert lib.hitchpark_nmpc_step(nmpc._handle, good, _Pose(), None, 3, out, ctypes.byref(status)) == 1
    assert lib.hitchpark_nmpc_step(nmpc._handle, good, _Pose(), None, -1, out, ctypes.byref(status)) == 9
    assert lib.hitchpark_nmpc_step(nmpc._handle, good, _Pose(math.inf, 0, 0), None, 0, out, None) == 9
    junk = (ctypes.c_double * 8)()
    assert lib.hitchpark_nmpc_step(junk, good, _Pose(), None, 0, out, ctypes.byref(status)) == 2
    assert lib.hitchpark_nmpc_init(junk, 8) is None  # too small
    for clearance, code in ((math.nan, 9), (-0.1, 9), (0.3, 0)):  # a held clearance: finite and not negative
        assert lib.hitchpark_nmpc_hold_clearance(nmpc._handle, clearance) == code
    assert lib.hitchpark_nmpc_hold_clearance(junk, 0.3) == 2
    # the workspace is sound: after a reset, the same answer as a fresh controller's
    lib.hitchpark_nmpc_reset(nmpc._handle, 0.05)
    fresh, _ = _api(library)
    lib.hitchpark_nmpc_reset(fresh._handle, 0.05)
    assert _step(lib, nmpc._handle, good)[1] == _step(lib, fresh._handle, good)[1]


def test_two_controllers_run_side_by_side(library):
    one, lib = _api(library)
    two, _ = _api(library)
    alone, _ = _api(library)
    m = [_Measurement(9.0 - 0.1 * k, 1.0, 0.3, 0.1, 0.0, -0.1 * min(k, 5)) for k in range(6)]
    other = _Measurement(6.0, -2.0, -0.4, -0.2, 0.1, 0.0)
    answers = []
    for k in range(6):
        answers.append(_step(lib, one._handle, m[k])[1])
        _step(lib, two._handle, other)  # the other controller between every step
    assert answers == [_step(lib, alone._handle, m[k])[1] for k in range(6)]


def test_the_python_face_of_the_library_refuses_what_it_cannot_do(library):
    nmpc, lib = _api(library)
    with pytest.raises(ValueError, match="reference must be"):
        nmpc.follow(object())
    settings = nmpc.settings
    straight = np.column_stack([np.linspace(10.0, 0.0, 201), np.zeros((201, 3))])
    other = PathReference(straight, Pose(), 0.5, 1.0, settings.prediction_dt, settings.horizon + 1)
    with pytest.raises(ValueError, match="horizon"):
        nmpc.follow(other)
    long = np.column_stack([np.linspace(200.0, 0.0, 4001), np.zeros((4001, 3))])  # 4001 points: past the most
    with pytest.raises(ValueError, match="refused the path"):
        nmpc.follow(PathReference(long, Pose(), 0.5, 1.0, settings.prediction_dt, settings.horizon))
    wall = Obstacle("wall", np.array([[0.0, 3.0], [9.0, 3.0], [9.0, 3.5], [0.0, 3.5]]))
    with pytest.raises(ValueError, match="clearance_m"):
        nmpc.keep_clear(Scene((wall,)), 11.0)
    nmpc.keep_clear(Scene((wall,)), 0.2)  # this package has the obstacle OCP
    angles = np.linspace(0.0, 2.0 * np.pi, 20, endpoint=False)
    tank = Obstacle("tank", np.column_stack([5.0 + np.cos(angles), 5.0 + np.sin(angles)]))  # convex, 20 vertices
    with pytest.raises(ValueError, match="at most 16 vertices each"):
        nmpc.keep_clear(Scene((tank,)), 0.2)
    # The C refuses a scene it cannot take: a piece of two vertices, a NaN, too many pieces, none given.
    square = (ctypes.c_double * 8)(0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0)
    for counts, n, code in (((2,), 1, 9), ((4,), 1_000_000, 9), ((4,), 1, 0)):
        assert lib.hitchpark_nmpc_keep_clear(nmpc._handle, square, (ctypes.c_int * 1)(*counts), n, 0.2) == code
    nan = (ctypes.c_double * 8)(0.0, 0.0, math.nan, 0.0, 1.0, 1.0, 0.0, 1.0)
    assert lib.hitchpark_nmpc_keep_clear(nmpc._handle, nan, (ctypes.c_int * 1)(4), 1, 0.2) == 9
    assert lib.hitchpark_nmpc_keep_clear(nmpc._handle, None, None, 1, 0.2) == 1
    assert lib.hitchpark_nmpc_keep_clear(nmpc._handle, square, (ctypes.c_int * 1)(4), 1, -0.1) == 9
    assert lib.hitchpark_nmpc_keep_clear(nmpc._handle, None, None, 0, 0.2) == 0  # open space again
    # The C refuses a path it cannot take: a NaN point, too many points, none given.
    points = (ctypes.c_double * 10)(0.0, 0.0, 0.0, 0.0, 0.0, math.nan, 0.0, 0.0, 0.0, 0.0)
    assert lib.hitchpark_nmpc_follow(nmpc._handle, points, 2, 0.5, 1.0) == 9
    assert lib.hitchpark_nmpc_follow(nmpc._handle, points, 1, 0.0, 1.0) == 9  # no speed
    assert lib.hitchpark_nmpc_follow(nmpc._handle, points, 1_000_000, 0.5, 1.0) == 9
    assert lib.hitchpark_nmpc_follow(nmpc._handle, None, 2, 0.5, 1.0) == 1
    assert lib.hitchpark_nmpc_follow(nmpc._handle, points, 1, 0.5, 1.0) == 0
    assert lib.hitchpark_nmpc_follow(nmpc._handle, None, 0, 0.0, 0.0) == 0  # park at the goal again
    # A refused measurement: the stop, the status, no plan and no cost, as the in-process controller answers it.
    in_process = make_nmpc(nmpc.vehicle, settings)
    for measurement in (
        Measurement(0.0, State(8.0, 1.0, 0.2, 1.5), 0.0, 0.0),
        Measurement(0.0, State(8.0, 1.0, 0.2, 0.1), math.nan, 0.0),  # the steer sensor gives NaN
    ):
        step, expected = (c.act(measurement, Pose(), (Command(0.0, 0.0),)) for c in (nmpc, in_process))
        assert not step.ok and step.stop and step.status == expected.status
        assert (step.rear_speed, step.front_steer, step.solve_ms) == (expected.rear_speed, expected.front_steer, 0.0)
        assert math.isnan(step.cost) and math.isnan(expected.cost)
        assert np.isnan(step.predicted_states).all() and np.isnan(step.predicted_inputs).all()
        assert step.predicted_states.shape == expected.predicted_states.shape


@pytest.mark.slow
def test_the_example_parks_from_random_as_park_does(built, compiled_in_process):
    run = subprocess.run([str(built.example)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr  # parked within 5 cm
    rows = np.array([[float(v) for v in line.split(",")] for line in run.stdout.splitlines()[1:]])
    sc = builtin_scenario("random")
    result = park(sc.vehicle, sc.start, sc.goal, sil_settings(sc.settings), sc.name, plant=sc.plant)
    assert len(result.stages) == 1  # one reverse stage: the example's whole maneuver
    traj = result.trajectory
    assert len(rows) == len(traj["t"])
    columns = ("t", "x_trailer", "y_trailer", "yaw_trailer", "hitch", "front_steer", "rear_speed")
    for i, name in enumerate((*columns, "front_steer_cmd", "rear_speed_cmd")):
        np.testing.assert_allclose(rows[:, i], np.asarray(traj[name], dtype=float), rtol=0, atol=1e-9, err_msg=name)
    assert math.hypot(rows[-1, 1] - traj["x_trailer"][-1], rows[-1, 2] - traj["y_trailer"][-1]) <= 1e-6


SINGLE_PRECISION = Path(__file__).parents[2] / "benchmarks" / "settings" / "single_precision.toml"


@pytest.mark.slow
def test_in_single_precision_the_example_parks_as_park_does_in_double(tmp_path, c_compiler, compiled_in_process):
    """Built with -DHITCHPARK_REAL=float (warnings as errors) from benchmarks/settings/single_precision.toml (a
    tolerance float resolves: 1e-3), the example parks from random's start, row for row with hitchpark's own double
    precision maneuver of the same settings, its trailer within 0.1 mm and its commanded steer within 1e-3 rad."""
    sc = builtin_scenario("random")
    settings = sil_settings(sc.settings, load_settings(SINGLE_PRECISION).nmpc)
    assert settings.nmpc.solver_options == {"tol": 1e-3, "mu": 1e-4}
    copy_package(package_files(ExportSpec(sc.vehicle, settings.nmpc, sc.start, sc.goal, sc.plant, sc.name)), tmp_path)
    done = _build(c_compiler, tmp_path, "-DHITCHPARK_REAL=float", "-O0", "-DHP_OPTIMIZE_AS_BUILT")  # quicker to build
    assert done.returncode == 0 and not done.stderr.strip(), done.stderr
    run = subprocess.run([str(tmp_path / "example")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr  # parked within 5 cm
    rows = np.array([[float(v) for v in line.split(",")] for line in run.stdout.splitlines()[1:]])
    traj = park(sc.vehicle, sc.start, sc.goal, settings, sc.name, plant=sc.plant).trajectory
    assert len(rows) == len(traj["t"])
    trailer = np.hypot(rows[:, 1] - np.asarray(traj["x_trailer"]), rows[:, 2] - np.asarray(traj["y_trailer"]))
    assert trailer.max() <= 1e-4
    assert np.abs(rows[:, 7] - np.asarray(traj["front_steer_cmd"])).max() <= 1e-3
    assert not np.array_equal(rows[:, 7], np.asarray(traj["front_steer_cmd"]))  # float's rounding, not double's


@pytest.mark.slow
def test_no_allocation_after_init_counted_by_an_interposed_allocator(built, c_compiler):
    """2000 steps in closed loop, some refused (a NaN hitch), with malloc, calloc and realloc counted for the whole
    process (tests/export/allocations.c): none after init; the counter itself counts the program's own malloc."""
    folder, probe = built.folder, Path(__file__).with_name("allocations.c")
    command = [c_compiler, "-std=gnu99", "-O1", "-fno-builtin", "-ffp-contract=off", f"-I{folder / 'include'}",
               f"-I{folder / 'examples'}", str(probe), str(folder / "examples" / "example_plant.c"),
               *map(str, built.objects), "-lm", "-o", str(folder / "allocations")]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0 and "__libc_malloc" in done.stderr:
        pytest.skip("this C library has no __libc_malloc to forward to (not glibc): allocations not counted")
    assert done.returncode == 0, done.stderr
    run = subprocess.run([str(folder / "allocations")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    after_init, after_steps, after_own, solved, refused = map(int, run.stdout.split())
    assert solved > 1500 and refused >= 2000 // 97
    assert after_steps == after_init  # not one allocation in 2000 steps
    assert after_own == after_steps + 1  # the counter counts


#: What the package may call: libm, and what a C compiler may call in any environment (GCC requires memcpy,
#: memmove, memset and memcmp even of a freestanding one).
LIBM = {"sqrt", "sin", "cos", "sincos", "tan", "atan", "atan2", "asin", "acos", "exp", "log", "pow", "fabs", "fmax",
        "fmin", "fmod", "floor", "ceil", "round", "trunc", "hypot", "copysign", "sinh", "cosh", "tanh", "expm1",
        "log1p", "nearbyint"}  # fmt: skip
FREESTANDING = {"memcpy", "memmove", "memset", "memcmp"}
#: Symbols the linker defines (a position-independent object taking a function's address refers to the GOT).
LINKER = {"_GLOBAL_OFFSET_TABLE_"}


def _symbols(nm: str, objects: list[Path]) -> tuple[set[str], set[str]]:
    """The symbols the objects need from elsewhere, and those they define."""
    needed, defined = set(), set()
    for obj in objects:
        for line in subprocess.run([nm, str(obj)], capture_output=True, text=True, check=True).stdout.splitlines():
            parts = line.split()
            if len(parts) >= 2 and parts[-2] == "U":
                needed.add(parts[-1])
            elif len(parts) == 3 and parts[1] in "TDRBCV":
                defined.add(parts[2])
    return needed - defined, defined


@pytest.mark.slow
def test_the_library_needs_nothing_but_libm_and_the_clock_it_names(built, c_compiler):
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("no nm on this machine: the library's symbols are not read")
    folder = built.folder
    unclocked = folder / "unclocked.o"
    command = [c_compiler, *WARNINGS, "-fPIC", "-DHITCHPARK_NMPC_NO_CLOCK", f"-I{folder / 'include'}", "-c",
               str(folder / "src" / "hitchpark_nmpc.c"), "-o", str(unclocked)]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    others = [obj for obj in built.objects if obj.stem != "hitchpark_nmpc"]
    for tick, clock in ((folder / "hitchpark_nmpc.o", {"clock_gettime"}), (unclocked, set())):
        needed, defined = _symbols(nm, [tick, *others])
        assert "hitchpark_nmpc_step" in defined and "hitchpark_nmpc_keep_clear" in defined
        assert needed - LIBM - FREESTANDING - LINKER == clock, needed


@pytest.mark.slow
def test_the_example_runs_clean_under_the_address_and_undefined_sanitizers(open_space_files, tmp_path, c_compiler):
    """The default package (parking and tracking in open space) built with AddressSanitizer and
    UndefinedBehaviorSanitizer: the example's closed loop parks, and the 2,000 steps of the allocation test's loop
    (restarts, a NaN hitch every 97th) run, with nothing reported."""
    probe = tmp_path / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    sanitize = [
        "-g",
        "-O0",
        "-DHP_OPTIMIZE_AS_BUILT",
        "-fsanitize=address,undefined",
        "-fno-sanitize-recover=all",
        "-fno-omit-frame-pointer",
    ]
    if subprocess.run([c_compiler, *sanitize, str(probe), "-o", str(tmp_path / "probe")]).returncode != 0:
        pytest.skip(f"{c_compiler} builds no sanitized program on this machine")
    folder = tmp_path / "pkg"
    copy_package(open_space_files, folder)
    include = [f"-I{folder / 'include'}", f"-I{folder / 'examples'}"]
    objects = []
    for source in sorted((folder / "src").glob("*.c")):
        obj = folder / (source.stem + ".o")
        done = subprocess.run([c_compiler, *WARNINGS, *sanitize, *include, "-c", str(source), "-o", str(obj)],
                              capture_output=True, text=True)  # fmt: skip
        assert done.returncode == 0, done.stderr
        objects.append(str(obj))
    plant = str(folder / "examples" / "example_plant.c")
    loops = {  # the example, and the allocation test's loop without its counting allocator
        "example": [*WARNINGS, *sanitize, str(folder / "examples" / "main.c")],
        "steps": ["-std=gnu99", "-DNOT_COUNTED", *sanitize, str(Path(__file__).with_name("allocations.c"))],
    }
    for name, flags_and_sources in loops.items():
        command = [c_compiler, *include, *flags_and_sources, plant, *objects, "-lm", "-o", str(folder / name)]
        done = subprocess.run(command, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    run = subprocess.run([str(folder / "example")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and not run.stderr.strip(), run.stderr[-2000:]  # parked, and nothing reported
    assert len(run.stdout.splitlines()) > 100
    run = subprocess.run([str(folder / "steps")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and not run.stderr.strip(), run.stderr[-2000:]
    solved, refused = map(int, run.stdout.split()[3:])
    assert solved + refused == 2000 and refused >= 2000 // 97
