"""``hitchpark export``: the full-model NMPC as a self-contained C99 package for an embedded target.

The package is the controller of one vehicle and one set of NMPC settings: hitchpark's own solver
(:data:`~hitchpark.solvers.riccati.RICCATI_SOURCE`, copied as it is: the very C of the in-process route), the
stage functions CasADi writes for that OCP, and the controller's tick around the solve
(``package/hitchpark_nmpc.c``: the measurement into the goal's frame, the commands in flight predicted out, the
warm start, the bounds, the command), the steps of :class:`~hitchpark.control.nmpc.FullNMPC` in the same
order and arithmetic. What it leaves out: the fallback solver (IPOPT, which the in-process controller asks by
default when the structured solver fails; ``hitchpark sil`` compares with the in-process controller without it),
the obstacle OCP and the tracking OCP. :func:`package_files` makes the files, :func:`write_package` writes them.
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import casadi as ca

from .. import __version__
from ..checks import InputError
from ..io import StagedFolder
from ..model.integrate import plant_function
from ..model.plant import PlantSettings
from ..model.state import Pose, State
from ..model.vehicle import VehicleTrailer
from ..ocp.full import FullParkingProblem
from ..ocp.settings import NMPCSettings
from ..solvers.casadi_patches import mark_unused_arguments
from ..solvers.riccati import RICCATI_SOURCE, riccati_standalone
from ..solvers.transcription import make_transcription

__all__ = ["PACKAGE_FILES", "ExportSpec", "package_files", "workspace_bound", "write_package"]

#: The files of a package, relative to its folder (what ``hitchpark export`` owns there).
PACKAGE_FILES = (
    "include/hitchpark_nmpc.h",
    "src/hitchpark_nmpc.c",
    "src/hitchpark_nmpc_config.h",
    "src/hitchpark_nmpc_functions.c",
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

#: The prefix of the generated functions' names (and so of their symbols).
PREFIX = "hitchpark_nmpc_f_"


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

    def __post_init__(self) -> None:
        check_exportable(self.nmpc)


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


def workspace_bound(config: dict[str, int]) -> int:
    """Bytes that hold the controller's struct on any usual ABI: each member rounded up to 8 bytes (no member
    is aligned to more), pointers counted as 8, 8 more per struct for its end. The C checks it when it compiles."""
    N, nx, nu, nr = config["HP_N"], config["HP_NX"], config["HP_NU"], config["HP_NR"]
    nv, nra = nx + nu, max(nr, 1)
    nc = 2 * nr + 2 * nv
    nw, ng = (N + 1) * nv - nu, nx + N * nx + N * nr
    r8 = lambda n: -(-n // 8) * 8  # noqa: E731
    reals = (
        3 * nv + nc + 3 * nc + 4 * nc + nc + 2 * nx + 2 + nv + 2 * nx + nx * nv + 2 * nra + nra * nx
        + 2 * nv * nv + nv + nx * nx + nx + nu * nu + nu * nx + 2 * nu + nx
    )  # fmt: skip
    stage = 8 * reals + r8(nc) + 8
    work = (N + 1) * stage + 8 * (config["HP_SZ_ARG"] + config["HP_SZ_RES"] + config["HP_SZ_IW"] + config["HP_SZ_W"])
    work += 8 * nx + r8(nx) + 8 + 8 * nx * nx + 16 + 16 * (config["HP_MAX_ITER"] + 1) + 8 + 16 + 8 + 8
    n_par = nx + N * config["HP_NP"] + config["HP_H0"]
    controller = 8 + work + 8 * (9 * nw + 6 * ng + n_par + nx + 4) + 5 * 8 + 8
    return r8(controller)


def _config_values(config: str) -> dict[str, int]:
    out: dict[str, int] = {}
    for line in config.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "#define" and parts[2].lstrip("-").isdigit():
            out[parts[1]] = int(parts[2])
    return out


def _functions(spec: ExportSpec) -> tuple[FullParkingProblem, Any, dict[str, ca.Function]]:
    """The OCP, its transcription and the model's steps the controller calls besides the solver: one controller
    sample (the commands in flight) and one prediction step (the cold start's rollout), as the in-process
    controller builds them."""
    problem = FullParkingProblem(spec.vehicle, spec.nmpc)
    transcription = make_transcription(problem)
    x, u = ca.SX.sym("x", 6), ca.SX.sym("u", 2)
    model = ca.Function(f"{PREFIX}model_step", [x, u], [problem.discrete_dynamics(x, u, spec.nmpc.dt)])
    predict = ca.Function(f"{PREFIX}predict_step", [x, u], [problem.discrete_dynamics(x, u)])
    return problem, transcription, {"HPC_MODEL_STEP": model, "HPC_PREDICT_STEP": predict}


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
    _, transcription, extra = _functions(spec)
    try:
        built = riccati_standalone(transcription, PREFIX, s.solver_options, extra)
    except RuntimeError as exc:
        raise InputError(f"nmpc.solver_options are not accepted by riccati_c: {exc}") from None
    assert built is not None  # multiple shooting, no path constraints
    solver_config, functions_c = built
    values = _config_values(solver_config)
    workspace = workspace_bound(values)
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
        "/* the solver's (riccati_ipm.inc) */" + solver_config
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
    )
    files = {
        "include/hitchpark_nmpc.h": header,
        "src/hitchpark_nmpc.c": _template("hitchpark_nmpc.c"),
        "src/hitchpark_nmpc_config.h": config,
        "src/hitchpark_nmpc_functions.c": '#include "hitchpark_nmpc_config.h"\n' + functions_c,
        "src/riccati_ipm.inc": RICCATI_SOURCE.read_text(encoding="utf-8"),
        **_example_files(spec),
        "cmake/arm-linux-gnueabihf.cmake": _template("arm-linux-gnueabihf.cmake"),
        "CMakeLists.txt": _template("CMakeLists.txt"),
        "Makefile": _template("Makefile"),
    }
    files["README.md"] = _readme(spec, workspace, values)
    manifest = {
        "format": "hitchpark-export/1",
        "hitchpark": __version__,
        "casadi": ca.CasadiMeta.version(),
        "settings": _settings_text(spec),
        "workspace_bytes": workspace,
        "sizes": {k: values[k] for k in ("HP_N", "HP_NX", "HP_NU", "HP_MAX_ITER")},
        "sha256": {name: hashlib.sha256(text.encode()).hexdigest() for name, text in sorted(files.items())},
    }
    files["manifest.json"] = json.dumps(manifest, indent=2, sort_keys=True, default=repr) + "\n"
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


def write_package(out: str | Path, files: dict[str, str], force: bool = False) -> Path:
    """Write ``files`` into the folder ``out``, whole or not at all (built aside, then published).

    A folder that exists and holds anything is refused (:class:`InputError`) unless ``force``; then the package's
    own files (:data:`PACKAGE_FILES`) are replaced and the rest left alone.
    """
    target = Path(out)
    if target.exists() and not target.is_dir():
        raise InputError(f"--out {target} is a file, not a folder")
    if target.is_dir() and any(target.iterdir()) and not force:
        raise InputError(f"--out {target} is not empty; pass --force to replace the package files in it")
    target.mkdir(parents=True, exist_ok=True)
    staged = StagedFolder(target, PACKAGE_FILES, "--out")
    with staged as folder:
        for name, text in files.items():
            path = folder / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    return target


def copy_package(files: dict[str, str], folder: Path) -> None:
    """Write ``files`` into an empty scratch ``folder`` (``hitchpark sil``'s build), no staging."""
    if folder.exists():
        shutil.rmtree(folder)
    for name, text in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
