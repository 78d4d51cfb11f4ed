"""``hitchpark export``: the full-model NMPC as a self-contained C99 package for an embedded target.

The package is the controller of one vehicle and one set of NMPC settings: hitchpark's own solver
(:func:`~hitchpark.solvers.riccati.riccati_source`, copied as it is: the very C of the in-process route), the
stage functions CasADi writes for each of its OCPs (:data:`OCPS`: parking at the goal, and tracking a planned
path to it), and the controller's tick around the solve (``package/hitchpark_nmpc.c``: the measurement into the
goal's frame, the commands in flight predicted out, the path's reference; ``package/hitchpark_nmpc_ocp.inc``,
compiled once per OCP: the warm start, the bounds, the solve cascade), the steps of
:class:`~hitchpark.control.nmpc.FullNMPC` in the same order and arithmetic. What it leaves out: the fallback
solver (IPOPT, which the in-process controller asks by default when the structured solver fails; ``hitchpark
sil`` compares with the in-process controller without it). With ``--obstacles`` the OCPs come again with the
scene's lines (:data:`GEOMETRY_FILES`). :func:`package_files` makes the files;
:func:`~.export_folder.write_package` writes them.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from importlib import resources
from typing import Any

import casadi as ca

from .. import __version__
from ..checks import InputError
from ..control.nmpc import COLD_ROUNDS
from ..model.integrate import plant_function
from ..model.plant import PlantSettings
from ..model.state import Pose, State
from ..model.vehicle import VehicleTrailer
from ..ocp.full import FullParkingProblem
from ..ocp.obstacles import CLEARANCE_LINES_SOURCE, CLEARANCE_PIECES_SOURCE, ClearanceConstraints, vehicle_shape
from ..ocp.separating import SEPARATING_LINES_SOURCE
from ..ocp.settings import NMPCSettings
from ..solvers.casadi_patches import mark_unused_arguments
from ..solvers.riccati import riccati_source, riccati_standalone
from ..solvers.transcription import make_transcription
from .export_memory import block_bound, workspace_bound

__all__ = [
    "OCPS",
    "PACKAGE_FILES",
    "ExportSpec",
    "library_sources",
    "package_files",
    "workspace_bound",
]

#: The package's OCPs, by the name of their C files: (tracking a path, keeping clear of a scene). The order is the
#: C's (``HPC_OCPS``); the last two only with ``--obstacles``.
OCPS = {"park": (False, False), "track": (True, False), "park_lines": (False, True), "track_lines": (True, True)}

#: The scene a package among obstacles takes at most: convex pieces, vertices a piece (``hitchpark_nmpc_keep_clear``).
MAX_PIECES, MAX_VERTICES = 128, 16

#: The files only a package among obstacles has: the geometry, hitchpark's own C files as the in-process route
#: compiles them.
GEOMETRY_FILES = {
    "src/geometry/clearance_lines.c": CLEARANCE_LINES_SOURCE,
    "src/geometry/clearance_pieces.c": CLEARANCE_PIECES_SOURCE,
    "src/geometry/separating_lines.c": SEPARATING_LINES_SOURCE,
}

#: The files of a package, relative to its folder (what ``hitchpark export`` owns there).
PACKAGE_FILES = (
    "include/hitchpark_nmpc.h",
    "src/hitchpark_nmpc.c",
    "src/hitchpark_nmpc_path.inc",
    "src/hitchpark_nmpc_scene.inc",
    "src/hitchpark_nmpc_config.h",
    "src/hitchpark_nmpc_internal.h",
    "src/hitchpark_nmpc_model.c",
    "src/hitchpark_nmpc_ocp.inc",
    *(f"src/hitchpark_nmpc_{part}_{name}.c" for name in OCPS for part in ("ocp", "functions")),
    *GEOMETRY_FILES,
    "src/riccati_ipm.inc",
    "examples/main.c",
    "examples/example_plant.c",
    "examples/example_scenario.h",
    "cmake/arm-linux-gnueabihf.cmake",
    "CMakeLists.txt",
    "Makefile",
    "README.md",
    "manifest.json",
)

#: The prefix of the generated functions' names (and so of their symbols); an OCP's add its name.
PREFIX = "hitchpark_nmpc_f_"

#: Points of a path the package tracks at most (``HITCHPARK_NMPC_MAX_PATH``): 102 m at hitchpark's 5 cm.
MAX_PATH = 2048


@dataclass(frozen=True)
class ExportSpec:
    """What a package is made of: the controller's vehicle and NMPC settings, and for its example the start,
    the goal, the plant (ideal or realistic; its delay the commands in flight) and the scenario's name."""

    vehicle: VehicleTrailer = field(default_factory=VehicleTrailer)
    nmpc: NMPCSettings = field(default_factory=NMPCSettings)
    start: State = field(default_factory=lambda: State(10.0, 0.0, 0.0, 0.0))
    goal: Pose = field(default_factory=Pose)
    plant: PlantSettings = field(default_factory=lambda: PlantSettings(kind="ideal"))
    scenario: str = ""
    max_time: float = 300.0
    obstacles: bool = False  # the obstacle OCP too (hitchpark_nmpc_keep_clear)

    def __post_init__(self) -> None:
        check_exportable(self.nmpc)
        if self.obstacles and self.nmpc.obstacle_planes < 1:
            raise InputError("--obstacles needs nmpc.obstacle_planes of 1 or more (the lines a body keeps at a step)")

    @property
    def ocps(self) -> dict[str, tuple[bool, bool]]:
        """The OCPs of this package: parking and tracking, and among obstacles both with the scene's lines."""
        return {name: kind for name, kind in OCPS.items() if self.obstacles or not kind[1]}


def check_exportable(settings: NMPCSettings) -> None:
    """Raise :class:`InputError` in one line for settings the package does not implement."""
    if settings.kind != "full":
        raise InputError(f"export writes the full-model NMPC (nmpc.kind 'full'), got nmpc.kind {settings.kind!r}")
    if settings.solver != "riccati_c":
        raise InputError(f"export writes hitchpark's own solver (nmpc.solver 'riccati_c'), got {settings.solver!r}")
    if settings.transcription != "multiple_shooting":
        raise InputError("export needs nmpc.transcription 'multiple_shooting'")


def _template(name: str) -> str:
    return (resources.files("hitchpark.app") / "package" / name).read_text(encoding="utf-8")


def _c(value: float) -> str:
    """A double as C reads it back exactly."""
    if math.isinf(value):
        return "INFINITY" if value > 0 else "(-INFINITY)"
    text = repr(float(value))
    return f"({text})" if text.startswith("-") else text


def _config_values(config: str) -> dict[str, int]:
    out: dict[str, int] = {}
    for line in config.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "#define" and parts[2].lstrip("-").isdigit():
            out[parts[1]] = int(parts[2])
    return out


def _model_functions(spec: ExportSpec) -> dict[str, ca.Function]:
    """The model's steps the controller calls besides the solver: one controller sample (the commands in flight)
    and one prediction step (the cold start's rollout), as the in-process controller builds them."""
    problem = FullParkingProblem(spec.vehicle, spec.nmpc)
    x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 2)
    model = ca.Function(f"{PREFIX}model_step", [x, u], [problem.discrete_dynamics(x, u, spec.nmpc.dt)])
    predict = ca.Function(f"{PREFIX}predict_step", [x, u], [problem.discrete_dynamics(x, u)])
    return {"HPC_MODEL_STEP": model, "HPC_PREDICT_STEP": predict}


def _ocp_files(spec: ExportSpec, name: str, tracking: bool, lines: bool) -> tuple[dict[str, int], dict[str, str]]:
    """One OCP's definitions (its sizes) and its two C files: the solver and the tick for its sizes, and its stage
    functions as CasADi writes them."""
    clearance = ClearanceConstraints(spec.vehicle, spec.nmpc.obstacle_planes) if lines else None
    transcription = make_transcription(FullParkingProblem(spec.vehicle, spec.nmpc, clearance, tracking))
    try:
        built = riccati_standalone(transcription, f"{PREFIX}{name}_", spec.nmpc.solver_options)
    except RuntimeError as exc:
        raise InputError(f"nmpc.solver_options are not accepted by riccati_c: {exc}") from None
    assert built is not None  # multiple shooting, no path constraints
    definitions, functions_c = built
    title = ("tracking a planned path to the goal" if tracking else "parking at the goal") + (
        ", keeping clear of the scene" if lines else ""
    )
    ocp = (
        f"/* hitchpark_nmpc_ocp_{name}.c: the OCP {title} (generated by hitchpark {__version__}): its sizes,\n"
        " * the solver and the controller's part of the tick, compiled for them. */\n"
        '#include "hitchpark_nmpc_internal.h"\n'
        + definitions
        + f"#define HPC_OCP_TRACKING {int(tracking)}\n#define HPC_OCP_LINES {int(lines)}\n"
        + f"#define HPC_OCP_BYTES HPC_OCP_BYTES_{name}\n"
        + "".join(f"#define HPC_OCP_{part.upper()} hpc_{name}_{part}\n"
                  for part in ("cascade", "solve_from", "plan", "report"))
        + '#include "riccati_ipm.inc"\n#include "hitchpark_nmpc_ocp.inc"\n'
    )  # fmt: skip
    files = {
        f"src/hitchpark_nmpc_ocp_{name}.c": ocp,
        f"src/hitchpark_nmpc_functions_{name}.c": '#include "hitchpark_nmpc_config.h"\n' + functions_c,
    }
    return _config_values(definitions), files


def _geometry_files() -> dict[str, str]:
    return {name: path.read_text(encoding="utf-8") for name, path in GEOMETRY_FILES.items()}


def library_sources(files: dict[str, str]) -> list[str]:
    """The package's C files of the library (not the example's, nor those another includes), in a fixed order."""
    return sorted(name for name in files if name.startswith("src/") and name.count("/") == 1 and name.endswith(".c"))


def _settings_text(spec: ExportSpec) -> dict[str, Any]:
    return {
        "vehicle": asdict(spec.vehicle),
        "nmpc": asdict(spec.nmpc),
        "example": {
            "scenario": spec.scenario,
            "start": asdict(spec.start),
            "goal": asdict(spec.goal),
            "plant": spec.plant.to_dict(),
        },
    }


def package_files(spec: ExportSpec) -> dict[str, str]:
    """Every file of the package, by its path in the package folder."""
    s, v = spec.nmpc, spec.vehicle
    assert s.prediction_dt is not None and s.horizon is not None
    files: dict[str, str] = {}
    sizes: dict[str, dict[str, int]] = {}
    for name, (tracking, lines) in spec.ocps.items():
        sizes[name], ocp_files = _ocp_files(spec, name, tracking, lines)
        files.update(ocp_files)
    model = _model_functions(spec)
    generator = ca.CodeGenerator(f"{PREFIX}model.c", {"main": False, "with_header": False})
    for function in model.values():
        generator.add(function)
    work = {
        "HPC_FN_SZ_ARG": max(f.sz_arg() for f in model.values()),
        "HPC_FN_SZ_RES": max(f.sz_res() for f in model.values()),
        "HPC_FN_SZ_IW": max(max(f.sz_iw() for f in model.values()), 1),
        "HPC_FN_SZ_W": max(max(f.sz_w() for f in model.values()), 1),
    }
    blocks = {name: block_bound(values) for name, values in sizes.items()}
    clearance = ClearanceConstraints(v, s.obstacle_planes)
    n_lines = clearance.n_params if spec.obstacles else 1
    workspace = workspace_bound(blocks, s.horizon, work, MAX_PATH, n_lines)
    if spec.obstacles:  # the scene, framed, the lines' scratch, a cold start's plans (hitchpark_nmpc.c)
        nw = (s.horizon + 1) * 8 - 2
        workspace += 8 * (MAX_PIECES * MAX_VERTICES * 11 + MAX_PIECES * (11 + MAX_VERTICES) + (s.horizon + 1) * 6)
        workspace += 8 * (3 * nw + 8) + 4 * 8 + 8 * 3 * 2
    step = float(s.prediction_dt)
    ramp = max(1, round(0.5 * abs(s.speed_min) / (v.max_accel * step)))  # FullNMPC._cold_inputs
    constants = {
        "HPC_DT": s.dt,
        "HPC_PREDICTION_DT": step,
        "HPC_MAX_STEER": v.max_steer,
        "HPC_MAX_STEER_RATE": v.max_steer_rate,
        "HPC_MAX_ACCEL": v.max_accel,
        "HPC_MAX_HITCH": v.max_hitch,
        "HPC_HITCH_BOUND": v.max_hitch - s.hitch_margin,
        "HPC_SPEED_MIN": s.speed_min,
        "HPC_SPEED_MAX": s.speed_max,
        "HPC_STOP_SPEED": s.stop_speed,
        "HPC_DUAL_FLOOR": float(s.dual_floor or 1e-9),
    }
    config = (
        "/* hitchpark_nmpc_config.h: the sizes, options and constants of this controller (generated by hitchpark "
        f"{__version__}). */\n#ifndef HITCHPARK_NMPC_CONFIG_H\n#define HITCHPARK_NMPC_CONFIG_H\n"
        "#ifndef HITCHPARK_REAL\n#define HITCHPARK_REAL double\n#endif\n"
        "#define casadi_real HITCHPARK_REAL\n#define casadi_int long long int\n"
        f"/* the OCPs (hitchpark_nmpc_ocp_NAME.c), each one's block [bytes] */\n"
        f"#define HPC_OCPS(X) {' '.join(f'X({name})' for name in spec.ocps)}\n"
        + "".join(f"#define HPC_OCP_BYTES_{name} {size}\n" for name, size in blocks.items())
        + f"#define HPC_N {s.horizon}\n"
        + "/* among obstacles: the lines a body keeps at a step, the numbers of a step's lines, the bodies */\n"
        + f"#define HPC_OBSTACLES {int(spec.obstacles)}\n#define HPC_PLANES {s.obstacle_planes}\n"
        + f"#define HPC_NL {n_lines}\n#define HPC_COLD_ROUNDS {COLD_ROUNDS}\n"
        + f"#define HPC_SHAPE {{{', '.join(_c(x) for x in vehicle_shape(v))}}}\n"
        + "/* the model's functions (hitchpark_nmpc_model.c) */\n"
        + "".join(f"#define {k} {value}\n" for k, value in work.items())
        + "".join(f"#define {macro} {function.name()}\n" for macro, function in model.items())
        + "/* the controller's (hitchpark_nmpc.c) */\n"
        + "".join(f"#define {k} {_c(value)}\n" for k, value in constants.items())
        + f"#define HPC_COLD_RAMP {ramp}\n#define HPC_WARM_DUALS {int(bool(s.warm_duals))}\n#endif\n"
    )  # fmt: skip
    header = (
        _template("hitchpark_nmpc.h")
        .replace("@VERSION@", __version__)
        .replace("@HORIZON@", str(s.horizon))
        .replace("@PREDICTION_DT@", repr(step))
        .replace("@DT@", repr(float(s.dt)))
        .replace("@WORKSPACE_BYTES@", str(workspace))
        .replace("@MAX_PATH@", str(MAX_PATH))
        .replace("@MAX_PIECES@", str(MAX_PIECES))
        .replace("@MAX_VERTICES@", str(MAX_VERTICES))
    )
    files.update(
        {
            "include/hitchpark_nmpc.h": header,
            "src/hitchpark_nmpc.c": _template("hitchpark_nmpc.c"),
            "src/hitchpark_nmpc_path.inc": _template("hitchpark_nmpc_path.inc"),
            "src/hitchpark_nmpc_scene.inc": _template("hitchpark_nmpc_scene.inc"),
            "src/hitchpark_nmpc_config.h": config,
            "src/hitchpark_nmpc_internal.h": _template("hitchpark_nmpc_internal.h"),
            "src/hitchpark_nmpc_ocp.inc": _template("hitchpark_nmpc_ocp.inc"),
            "src/hitchpark_nmpc_model.c": '#include "hitchpark_nmpc_config.h"\n'
            + mark_unused_arguments(generator.dump()),
            "src/riccati_ipm.inc": riccati_source(),
            **(_geometry_files() if spec.obstacles else {}),
            **_example_files(spec),
            "cmake/arm-linux-gnueabihf.cmake": _template("arm-linux-gnueabihf.cmake"),
        }
    )
    sources = " ".join(library_sources(files))
    files["CMakeLists.txt"] = _template("CMakeLists.txt").replace("@SOURCES@", sources)
    files["Makefile"] = _template("Makefile").replace("@SOURCES@", sources)
    files["README.md"] = _readme(spec, workspace, sizes["park"])
    manifest = {
        "format": "hitchpark-export/2",
        "hitchpark": __version__,
        "casadi": ca.CasadiMeta.version(),
        "settings": _settings_text(spec),
        "ocps": list(spec.ocps),
        "workspace_bytes": workspace,
        "sizes": {**{k: sizes["park"][k] for k in ("HP_N", "HP_NX", "HP_NU", "HP_MAX_ITER")}, "MAX_PATH": MAX_PATH},
        "sha256": {name: hashlib.sha256(text.encode()).hexdigest() for name, text in sorted(files.items())},
    }
    files["manifest.json"] = json.dumps(manifest, indent=2, sort_keys=True, default=repr) + "\n"
    assert set(files) <= set(PACKAGE_FILES)
    return files


def _example_files(spec: ExportSpec) -> dict[str, str]:
    """The example's plant (the scenario's, without noise: hitchpark's ideal plant, RK4 sub-steps of the full
    kinematics) and its scenario."""
    real = spec.plant.resolve_vehicle(spec.vehicle)
    plant = plant_function(real)
    named = ca.Function("hitchpark_example_plant", [*plant.sx_in()], [*plant.call(plant.sx_in())])
    generator = ca.CodeGenerator("example_plant.c", {"main": False, "with_header": False})
    generator.add(named)
    code = mark_unused_arguments(generator.dump())
    v, s = spec.vehicle, spec.nmpc
    values = {
        "EX_START_X": spec.start.x,
        "EX_START_Y": spec.start.y,
        "EX_START_YAW": spec.start.yaw,
        "EX_START_HITCH": spec.start.hitch,
        "EX_GOAL_X": spec.goal.x,
        "EX_GOAL_Y": spec.goal.y,
        "EX_GOAL_YAW": spec.goal.yaw,
        "EX_DT": s.dt,
        "EX_MAX_TIME": spec.max_time,
        "EX_STEER_RATE": v.max_steer_rate,
        "EX_ACCEL": v.max_accel,
        "EX_PLANT_MAX_STEER": real.max_steer,
        "EX_PLANT_MAX_HITCH": real.max_hitch,
        "EX_SETTLE_TOLERANCE": math.radians(0.5),
    }
    scenario = (
        f"/* The example's scenario{' (' + spec.scenario + ')' if spec.scenario else ''}: start, goal and plant. */\n"
        + "".join(f"#define {k} {_c(value)}\n" for k, value in values.items())
        + f"#define EX_DELAY {spec.plant.delay_steps}\n#define EX_MAX_STEPS {s.max_steps}\n"
        + f"#define EX_PLANT_SZ_W {max(1, int(named.sz_w()))}\n#define EX_PLANT_SZ_IW {max(1, int(named.sz_iw()))}\n"
    )
    if spec.plant.kind != "ideal":
        scenario += "/* the scenario's plant is realistic; the example drives the ideal one (commands act at once) */\n"
    return {
        "examples/main.c": _template("main.c"),
        "examples/example_plant.c": '#include "../src/hitchpark_nmpc_config.h"\n' + code,
        "examples/example_scenario.h": scenario,
    }


def _readme(spec: ExportSpec, workspace: int, values: dict[str, int]) -> str:
    s, v = spec.nmpc, spec.vehicle
    settings = json.dumps(_settings_text(spec), indent=2, sort_keys=True, default=repr)
    return (
        _template("README.md")
        .replace("@VERSION@", __version__)
        .replace("@WORKSPACE_BYTES@", str(workspace))
        .replace("@HORIZON@", str(s.horizon))
        .replace("@PREDICTION_DT@", repr(float(s.prediction_dt or s.dt)))
        .replace("@DT@", repr(float(s.dt)))
        .replace("@MAX_ITER@", str(values["HP_MAX_ITER"]))
        .replace("@MAX_STEER@", f"{v.max_steer:.6g}")
        .replace("@MAX_HITCH@", f"{v.max_hitch:.6g}")
        .replace("@SETTINGS@", settings)
    )
