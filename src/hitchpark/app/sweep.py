"""Sweeps: park from many random starts and see where the maneuver succeeds.

A sweep is a pure function of its :class:`SweepConfig`: the ``n`` starts are drawn up front
from ``numpy.random.default_rng(seed)``, uniformly over a :class:`Region` of the world frame
(trailer-axle position and heading, hitch angle; by default the goal is at the origin, heading 0,
so it is the parking frame), so case ``i`` is the same whatever runs it. Over a scene of obstacles
(a scenario's, :func:`config_from_scenario`), a start that does not keep
:attr:`~hitchpark.maneuver.settings.ManeuverSettings.start_clearance_m` (``success.min_clearance_m``, the
guard's margin and the planner's for a start: nearer, the car cannot move away) clear of it is drawn again,
and counted as skipped (:func:`draw_clear_starts`). Each case parks once;
its :class:`~.records.CaseRecord` is appended to a JSONL file as soon as it is known, and a sweep run
again on the same file runs only the cases it lacks (:func:`run_sweep`).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..checks import InputError, check_int
from ..control.nmpc import FullNMPC, TrailerNMPC, make_nmpc
from ..io import format_tag, read_toml, write_json
from ..maneuver.planned import prepare_scene
from ..maneuver.process import park
from ..maneuver.result import ManeuverSettings
from ..maneuver.scenario import Scenario
from ..model.plant import PlantSettings, load_plant
from ..model.scene import Scene
from ..model.state import Pose
from ..model.vehicle import VehicleTrailer
from ..outputs import check_output_file, check_output_folder
from .executors import Executor, make_executor
from .records import CaseRecord, RecordWriter, Start, case_record, scan_records
from .report import Render
from .starts import DEFAULT_REGION, MAX_CASES, Region, _ClearOf, draw_clear_starts, parse_region
from .summary import summarize

__all__ = [
    "GOAL",
    "CaseTask",
    "SweepConfig",
    "SweepOutcome",
    "build_config",
    "config_from_scenario",
    "controller_for",
    "kept_folder",
    "load_settings",
    "run_case",
    "run_sweep",
    "settings_from_dict",
]

#: The goal of every case: the origin of the parking frame, heading 0.
GOAL = Pose()


@dataclass(frozen=True, kw_only=True)
class SweepConfig:
    """Everything a sweep's results depend on. Picklable: it travels to the workers.

    ``plant`` is passed through to :func:`~hitchpark.maneuver.park` as ``plant=`` when it is not None;
    ``goal`` and ``scene`` as they are (default: the origin heading 0, open space). Over a scene, starts
    that do not keep ``settings.start_clearance_m`` clear of it are drawn again (:meth:`draw`).
    ``scenario`` names the scenario the sweep came from ("" if none), for its summary. ``exported``: the library of
    the exported controller (:func:`~.exported.exported_controller_library`) that drives every case instead of
    the in-process one.
    """

    vehicle: VehicleTrailer = field(default_factory=VehicleTrailer)
    settings: ManeuverSettings = field(default_factory=ManeuverSettings)
    plant: PlantSettings | None = None
    region: Region = DEFAULT_REGION
    seed: int
    n: int
    goal: Pose = GOAL
    scene: Scene = field(default_factory=Scene)
    scenario: str = ""
    exported: Path | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "seed", check_int("seed", self.seed, 0))
        object.__setattr__(self, "n", check_int("n", self.n, 1, MAX_CASES))
        self.vehicle.require_hitch_offset()
        self.region.check_vehicle(self.vehicle)
        self.region.check_vehicle(self.plant_vehicle)

    @property
    def plant_vehicle(self) -> VehicleTrailer:
        """The real car's lengths and limits: those whose bodies must keep clear of the scene."""
        return (self.plant or PlantSettings()).resolve_vehicle(self.vehicle)

    def draw(self) -> tuple[list[Start], int]:
        """The starts of the cases, and how many draws were skipped as they collide with the scene."""
        keep = None
        if not self.scene.is_empty:
            keep = _ClearOf(self.plant_vehicle, self.scene, self.settings.start_clearance_m)
        return draw_clear_starts(self.seed, self.n, self.region, keep)

    def starts(self) -> list[Start]:
        return self.draw()[0]


def settings_from_dict(data: Mapping[str, Any]) -> ManeuverSettings:
    """:class:`ManeuverSettings` from the tables ``nmpc``, ``forward`` and ``success`` (each optional)."""
    return ManeuverSettings.from_dict(data)


def load_settings(path: str | Path) -> ManeuverSettings:
    """Read :class:`ManeuverSettings` from a TOML file with ``[nmpc]``, ``[forward]``, ``[success]`` tables."""
    data = read_toml(path, "settings")
    try:
        return settings_from_dict(data)
    except (TypeError, ValueError) as exc:
        raise InputError(f"settings file {path}: {exc}") from None


def build_config(
    *,
    n: int,
    seed: int,
    region: str | None = None,
    vehicle: VehicleTrailer | None = None,
    settings_file: str | Path | None = None,
    plant_file: str | Path | None = None,
    scenario: Scenario | None = None,
) -> SweepConfig:
    """A :class:`SweepConfig` from the command's options: region text and settings and plant files.

    With ``scenario``, :func:`config_from_scenario`: its start region, goal, scene, vehicle, settings and
    plant, the last three replaced by ``vehicle`` and the files if given; ``region`` is refused then.
    """
    settings = load_settings(settings_file) if settings_file is not None else None
    plant = load_plant(plant_file) if plant_file is not None else None
    if scenario is not None:
        if region is not None:
            raise InputError("give --region or --scenario, not both: a scenario's starts come from its [start_region]")
        return config_from_scenario(scenario, n=n, seed=seed, vehicle=vehicle, settings=settings, plant=plant)
    vehicle = vehicle or VehicleTrailer()
    return SweepConfig(
        vehicle=vehicle,
        settings=settings or ManeuverSettings(),
        plant=plant,
        region=parse_region(region, vehicle) if region is not None else DEFAULT_REGION,
        seed=seed,
        n=n,
    )


def config_from_scenario(
    scenario: Scenario,
    *,
    n: int,
    seed: int,
    vehicle: VehicleTrailer | None = None,
    settings: ManeuverSettings | None = None,
    plant: PlantSettings | None = None,
) -> SweepConfig:
    """A sweep over the scenario's scene: starts from its ``[start_region]`` (world frame), to its goal.

    Its vehicle, settings and plant unless given. :class:`InputError` if the scenario has no start region.
    """
    if scenario.start_region is None:
        where = f" ({scenario.path})" if scenario.path is not None else ""
        raise InputError(
            f"scenario {scenario.name}{where} has no [start_region]: a sweep over it draws its starts there"
        )
    return SweepConfig(
        vehicle=vehicle or scenario.vehicle,
        settings=settings or scenario.settings,
        plant=plant or scenario.plant,
        region=Region(**scenario.start_region.to_dict()),  # type: ignore[arg-type]
        seed=seed,
        n=n,
        goal=scenario.goal,
        scene=scenario.scene,
        scenario=scenario.name,
    )


# --------------------------------------------------------------------------- one case, in a worker

_local = threading.local()


def controller_for(config: SweepConfig) -> TrailerNMPC | FullNMPC:
    """This worker's controller for ``config``, built once (it compiles the NLP, or loads the exported library) and
    then reused.

    One per process and thread, so workers that run several threads never share one.
    """
    key = (config.vehicle, config.settings.nmpc, config.exported)
    cached: tuple[Any, TrailerNMPC | FullNMPC] | None = getattr(_local, "controller", None)
    if cached is None or cached[0] != key:
        if config.exported is not None:
            from .exported import ExportedNMPC

            controller: TrailerNMPC | FullNMPC = ExportedNMPC(config.exported, config.vehicle, config.settings.nmpc)
        else:
            controller = make_nmpc(config.vehicle, config.settings.nmpc)
        cached = (key, controller)
        _local.controller = cached
    return cached[1]


@dataclass(frozen=True)
class CaseTask:
    """One case to run: the sweep's config, the case index and its start; where to keep its maneuver, if
    anywhere (``keep/case_NNNN/maneuver.json``, and what ``render`` draws there)."""

    config: SweepConfig
    case: int
    start: Start
    keep: Path | None = None
    render: Render | None = None


def kept_folder(keep: Path, case: int) -> Path:
    """Where the maneuver of ``case`` is kept under ``--keep-maneuvers keep``."""
    return Path(keep) / f"case_{case:04d}"


def run_case(task: CaseTask) -> CaseRecord:
    """Park from the task's start and measure it. Runs in a worker; the controller is the worker's."""
    config = task.config
    controller = controller_for(config)
    t0 = time.perf_counter()
    result = park(
        config.vehicle,
        task.start.state(),
        config.goal,
        config.settings,
        name=f"case {task.case}",
        controller=controller,
        plant=config.plant,
        scene=config.scene,
    )
    wall = time.perf_counter() - t0
    if task.keep is not None:
        folder = kept_folder(task.keep, task.case)
        folder.mkdir(parents=True, exist_ok=True)
        write_json(folder / "maneuver.json", result.to_dict())
        if task.render is not None:
            task.render(result, folder)
    return CaseRecord(case=task.case, start=task.start, **case_record(result, wall))


# --------------------------------------------------------------------------- the whole sweep


@dataclass(frozen=True)
class SweepOutcome:
    """A finished sweep: every record by case index, the summary, and what this run did."""

    records: tuple[CaseRecord, ...]
    summary: dict[str, Any]
    ran: int
    kept: int
    dropped_cut_line: bool
    elapsed_s: float
    where: str


def _progress_bar(total: int, initial: int, enabled: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="case", file=sys.stderr, disable=not enabled, dynamic_ncols=True)


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    executor: Executor | None = None,
    progress: bool = False,
    on_record: Callable[[CaseRecord], None] | None = None,
    keep: str | Path | None = None,
    render: Render | None = None,
) -> SweepOutcome:
    """Run the cases of ``config`` that ``out`` lacks, appending a line to it as each one finishes.

    ``out`` is a JSONL file of :class:`CaseRecord` lines. Lines already there are kept as they are if they
    belong to this sweep (same start for the same case index, every index below n); a last line cut
    off by a kill is dropped and its case run again. A file holding anything else is refused with an
    :class:`InputError` before anything is changed. ``executor`` runs the cases (default: this
    process); it is started only if there is something to run. ``progress`` shows a bar on stderr. ``keep``: a
    folder where each case run now keeps its ``maneuver.json`` (``case_NNNN/``, :func:`kept_folder`), and what
    ``render`` draws beside it (the command line's: the viewer); cases kept from ``out`` are not run again.

    Returns the records of all n cases, old and new, and their summary (:func:`~.records.summarize`,
    plus the seed, the region, ``skipped``: the starts drawn again as they collide with the scene, from
    a scenario its name and goal, and among obstacles ``prepare_s``: the seconds it took to build or load the
    scene's goal tree and compiled rollouts before the cases, not counted in their planning time).
    """
    out = check_output_file(out, "--out", append=True)  # a FIFO, a link, a device: refused, never read
    starts, skipped = config.draw()
    existing = scan_records(out, starts)
    records = dict(existing.records)
    keep = None if keep is None else check_output_folder(keep, "--keep-maneuvers")
    todo = [CaseTask(config, case, start, keep, render) for case, start in enumerate(starts) if case not in records]
    executor = make_executor("serial") if executor is None else executor
    t0 = time.perf_counter()
    prepare_s = None
    if todo and not config.scene.is_empty:
        # The scene's goal tree and the compiled rollouts, once, before the cases (each worker then loads them from
        # the disk cache, before its plans' clocks start): their time is reported apart from the plans'.
        prepare_scene(config.vehicle, config.goal, config.scene, config.settings)
        prepare_s = time.perf_counter() - t0
    if todo:
        # The controller, built here once before the file is touched: settings it refuses (a solver's option out of
        # range) leave the file as it was. The workers build their own; this process keeps this one (serial: reused).
        controller_for(config)
        parked = sum(r.success for r in records.values())
        # The executor starts first: if it cannot (a scheduler out of reach), the file is left as it was.
        with (
            executor as running,
            RecordWriter(out, existing) as writer,
            _progress_bar(config.n, len(records), progress) as bar,
        ):
            try:
                for record in running.imap_unordered(run_case, todo):
                    writer.write(record)
                    records[record.case] = record
                    parked += record.success
                    bar.set_postfix_str(f"parked {parked / len(records):.1%}", refresh=False)
                    bar.update()
                    if on_record is not None:
                        on_record(record)
            except BaseException:  # Ctrl-C or an error: the bar goes, the message that follows says why
                bar.leave = False
                raise
    ordered = tuple(records[case] for case in range(config.n))
    summary = {
        "format": format_tag("sweep-summary"),
        **summarize(ordered),
        "seed": config.seed,
        "region": config.region.to_dict(),
        "skipped": skipped,
    }
    if config.scenario:
        summary.update(scenario=config.scenario, goal=config.goal.to_dict())
    if config.exported is not None:
        summary["controller"] = "exported"
    if prepare_s is not None:
        summary["prepare_s"] = prepare_s
    return SweepOutcome(
        records=ordered,
        summary=summary,
        ran=len(todo),
        kept=len(existing.records),
        dropped_cut_line=existing.cut_bytes > 0,
        elapsed_s=time.perf_counter() - t0,
        where=executor.describe(),
    )
