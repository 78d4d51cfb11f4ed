"""Applications above the maneuver: reproducing the paper and saving reports (:mod:`.report`), and sweeps
of many random starts (``hitchpark sweep``, :mod:`.sweep`).

:func:`run_sweep` parks from the ``n`` starts of a :class:`SweepConfig` on an
:class:`~.executors.Executor` (this process, a process pool, Dask) and appends one
:class:`CaseRecord` per case to a JSONL file, resuming where a killed run stopped;
:func:`summarize` gives the numbers over all cases.
"""

from .executors import Executor, executor_names, make_executor, register_executor, sweep_executor
from .records import CaseRecord, Start, case_record, scan_records
from .starts import DEFAULT_REGION, Region, draw_starts, parse_region
from .summary import format_summary, summarize
from .sweep import SweepConfig, SweepOutcome, build_config, load_settings, run_sweep

__all__ = [
    "DEFAULT_REGION",
    "CaseRecord",
    "Executor",
    "Region",
    "Start",
    "SweepConfig",
    "SweepOutcome",
    "build_config",
    "case_record",
    "draw_starts",
    "executor_names",
    "format_summary",
    "load_settings",
    "make_executor",
    "parse_region",
    "register_executor",
    "run_sweep",
    "scan_records",
    "summarize",
    "sweep_executor",
]
