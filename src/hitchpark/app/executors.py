"""Where the cases of a sweep run: an open set of executors, chosen by name.

An executor is a context manager whose ``imap_unordered(fn, items)`` yields ``fn(item)`` for
every item, in the order they complete. It starts its workers on entering and stops them on
leaving. ``fn`` and the items must be picklable: they travel to other processes, maybe other
machines. Each executor keeps at most a few tasks per worker in flight, so a long sweep does
not queue all of its cases at once and stops soon when interrupted.

Registered here: ``serial`` (this process), ``pool`` (a process pool on this machine) and
``dask`` (``option`` ``"local"`` for a ``distributed.LocalCluster`` of ``workers`` processes, or the
address of a running scheduler). :func:`register_executor` adds another.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from itertools import islice
from typing import Any, Protocol, TypeVar

from ..checks import InputError, check_int
from .workers import WorkerPool, child_pids, sigint_blocked

__all__ = [
    "Executor",
    "executor_names",
    "make_executor",
    "register_executor",
    "sweep_executor",
]

#: Tasks in flight per worker: enough to keep every worker busy, few enough to stop soon.
TASKS_PER_WORKER = 4

#: The most worker processes accepted.
MAX_WORKERS = 1024

#: How long an interrupted Dask LocalCluster may take to close, once its workers are gone [s].
ABORT_TIMEOUT_S = 2.0


class Executor(Protocol):
    """Runs ``fn`` over ``items`` somewhere; a context manager that owns its workers."""

    def __enter__(self) -> Executor: ...

    def __exit__(self, *exc: object) -> None: ...

    def imap_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        """``fn(item)`` for each item, in completion order; a task's exception is raised here."""
        ...

    def describe(self) -> str:
        """A few words on where the tasks run, for messages."""
        ...


#: A factory builds an executor from the worker count and a backend-specific option; it checks
#: both but starts nothing (that happens on entering the executor).
ExecutorFactory = Callable[[int, str], Executor]

_EXECUTORS: dict[str, ExecutorFactory] = {}

F = TypeVar("F", bound=ExecutorFactory)


def register_executor(name: str) -> Callable[[F], F]:
    """Decorator: make the factory available as ``make_executor(name, ...)``."""

    def add(factory: F) -> F:
        _EXECUTORS[name] = factory
        return factory

    return add


def executor_names() -> tuple[str, ...]:
    return tuple(_EXECUTORS)


def make_executor(name: str, workers: int = 1, option: str = "") -> Executor:
    """The executor registered as ``name``, for ``workers`` workers (checked, not started)."""
    if name not in _EXECUTORS:
        raise InputError(f"unknown executor {name!r}; known: {', '.join(_EXECUTORS)}")
    workers = check_int("workers", workers, 1, MAX_WORKERS)
    return _EXECUTORS[name](workers, option)


def sweep_executor(workers: int | None = None, dask: str | None = None) -> Executor:
    """The executor the ``sweep`` command's options ask for.

    ``dask`` (``"local"`` or a scheduler address) picks Dask; otherwise a process pool of
    ``workers`` processes (default: one per core), or this process alone when ``workers`` is 1.
    """
    workers = check_int("workers", (os.cpu_count() or 1) if workers is None else workers, 1, MAX_WORKERS)
    if dask is not None:
        return make_executor("dask", workers, dask)
    return make_executor("pool" if workers > 1 else "serial", workers)


@register_executor("serial")
class SerialExecutor:
    """Every task in this process, one after the other."""

    def __init__(self, workers: int = 1, option: str = ""):
        if option:
            raise InputError(f"the serial executor takes no option, got {option!r}")

    def __enter__(self) -> SerialExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def imap_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        for item in items:
            yield fn(item)

    def describe(self) -> str:
        return "this process"


@register_executor("pool")
class PoolExecutor:
    """A pool of ``workers`` processes on this machine (started fresh: ``spawn``).

    The workers ignore SIGINT and end with this process (:class:`~.workers.WorkerPool`); leaving on
    an exception (Ctrl-C) cancels the queued cases and terminates the workers busy with one.
    """

    def __init__(self, workers: int, option: str = ""):
        if option:
            raise InputError(f"the pool executor takes no option, got {option!r}")
        self.workers = workers
        self._owner: WorkerPool | None = None
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> PoolExecutor:
        self._owner = WorkerPool(self.workers)
        self._pool = self._owner.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        owner, self._owner, self._pool = self._owner, None, None
        if owner is not None:
            owner.__exit__(*exc)

    def imap_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        pool = self._pool
        if pool is None:
            raise RuntimeError("enter the executor before using it")
        todo = iter(items)
        pending: set[Future[Any]] = {pool.submit(fn, item) for item in islice(todo, TASKS_PER_WORKER * self.workers)}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            pending |= {pool.submit(fn, item) for item in islice(todo, len(done))}
            for future in done:
                yield future.result()

    def describe(self) -> str:
        return f"a pool of {self.workers} processes"


@register_executor("dask")
class DaskExecutor:
    """Dask distributed: ``option`` ``"local"`` starts a LocalCluster here, else it names a scheduler.

    A LocalCluster has ``workers`` worker processes of one thread each. With an address the
    scheduler's own workers run the tasks (``workers`` does not apply); they need hitchpark installed.
    """

    def __init__(self, workers: int, option: str):
        option = option.strip()
        if not option:
            raise InputError("--dask must be 'local' or a scheduler address such as tcp://10.0.0.5:8786, got ''")
        self.workers = workers
        self.address = option
        self._client: Any = None
        self._cluster: Any = None
        self._loop: _QuietLoop | None = None
        self._children_before: set[int] | None = None

    @property
    def local(self) -> bool:
        return self.address == "local"

    def __enter__(self) -> DaskExecutor:
        try:
            import distributed
        except ImportError:
            raise InputError("--dask needs the Dask distributed package: pip install 'dask[distributed]'") from None
        if self.local:
            # The cluster's worker processes are started from its IO loop's threads; started from a
            # thread that holds SIGINT back, they hold it back too and leave Ctrl-C to this process.
            self._children_before = child_pids()
            self._loop = _QuietLoop()
            try:
                self._cluster = distributed.LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    # The scheduler serves HTTP (health, metrics) even without a dashboard, by default on
                    # port 8787, warning on stderr when another cluster holds that: any free port will do.
                    scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                    silence_logs=logging.ERROR,
                    loop=self._loop.ioloop,
                )
                self._client = distributed.Client(self._cluster, loop=self._loop.ioloop)
            except BaseException:  # Ctrl-C while the cluster starts, say
                self._abort()
                raise
        else:
            try:
                self._client = distributed.Client(self.address, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"cannot reach the Dask scheduler at --dask {self.address}: {exc}") from None
        return self

    def __exit__(self, *exc: object) -> None:
        if exc and exc[0] is not None and self.local:
            self._abort()
            return
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None
        if self._loop is not None:
            self._loop.stop()
            self._loop = None

    def _abort(self) -> None:
        """Stop a LocalCluster at once: its worker processes first, busy or not, then the rest.

        What the scheduler and the nannies log about workers gone and connections closed is
        beside the point now: it is not shown.
        """
        with _silenced("distributed", "tornado", "asyncio"):
            before, now = self._children_before, child_pids()
            if before is not None and now is not None:
                for pid in now - before:  # the cluster's workers (a SIGTERM-proof resource tracker stays)
                    with contextlib.suppress(OSError):
                        os.kill(pid, signal.SIGTERM)
            for part in (self._client, self._cluster):
                if part is not None:
                    with contextlib.suppress(Exception):
                        part.close(timeout=ABORT_TIMEOUT_S)
            self._client = self._cluster = None
            if self._loop is not None:
                self._loop.stop()
                self._loop = None

    def imap_unordered(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        from distributed import as_completed

        client = self._client
        if client is None:
            raise RuntimeError("enter the executor before using it")
        threads = self.workers if self.local else max(1, sum(client.nthreads().values()))
        todo = iter(items)
        running = as_completed(
            [client.submit(fn, item, pure=False) for item in islice(todo, TASKS_PER_WORKER * threads)]
        )
        for future in running:
            result = future.result()
            for item in islice(todo, 1):
                running.add(client.submit(fn, item, pure=False))
            future.release()
            yield result

    def describe(self) -> str:
        if self.local:
            return f"a Dask LocalCluster of {self.workers} processes"
        return f"the Dask scheduler at {self.address}"


@contextlib.contextmanager
def _silenced(*names: str) -> Iterator[None]:
    """Turn the named loggers and those below them off for the block."""
    below = [
        logger
        for name, logger in logging.root.manager.loggerDict.items()
        if isinstance(logger, logging.Logger) and name.startswith(tuple(f"{n}." for n in names))
    ]
    loggers = [logging.getLogger(name) for name in names] + below
    before = [logger.disabled for logger in loggers]
    for logger in loggers:
        logger.disabled = True
    try:
        yield
    finally:
        for logger, disabled in zip(loggers, before, strict=True):
            logger.disabled = disabled


class _QuietLoop:
    """An asyncio loop (as a Tornado IOLoop, for Dask) in a thread of its own that holds SIGINT back.

    Threads inherit the signal mask of the thread that starts them, and processes that of the
    thread that forks them: whatever this loop starts never sees a terminal's Ctrl-C.
    """

    def __init__(self) -> None:
        from tornado.ioloop import IOLoop

        ready = threading.Event()
        self._stopping: asyncio.Event | None = None
        self._aloop: asyncio.AbstractEventLoop | None = None

        async def serve() -> None:
            self._stopping = asyncio.Event()
            self._aloop = asyncio.get_running_loop()
            self.ioloop = IOLoop.current()
            ready.set()
            await self._stopping.wait()

        with sigint_blocked():
            self._thread = threading.Thread(
                target=asyncio.run, args=(serve(),), name="hitchpark-dask-loop", daemon=True
            )
            self._thread.start()
        ready.wait()

    def stop(self) -> None:
        """End the loop (asyncio.run cancels what is left on it) and its thread."""
        if self._aloop is not None and self._stopping is not None and not self._aloop.is_closed():
            with contextlib.suppress(RuntimeError):  # closed meanwhile
                self._aloop.call_soon_threadsafe(self._stopping.set)
        self._thread.join(timeout=ABORT_TIMEOUT_S)
