"""Worker processes that stay quiet on Ctrl-C, stop at once when told and never outlive their command.

A terminal's Ctrl-C sends SIGINT to the whole process group: the command and every worker it
started. Only the command should answer it (one line, exit status 130); the workers leave it to
the command, which stops them. So a worker ignores SIGINT from its first instruction on: it is
started with SIGINT blocked (a signal mask is inherited through fork and exec) and its initializer
then ignores it. When a command ends on an error or an interrupt, :class:`WorkerPool` does not wait
for the tasks running in its workers (a long solve, a figure half drawn): it cancels the queued
ones and terminates the workers.

A command killed outright (SIGKILL) cannot stop its workers; they end by themselves. On Linux a
worker asks the kernel to kill it when its parent dies (``prctl(PR_SET_PDEATHSIG)``); everywhere, a
thread of the worker checks every half second that its parent is still the one that started it.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from multiprocessing import current_process, resource_tracker
from multiprocessing.context import SpawnContext, SpawnProcess
from types import FrameType
from typing import Any, ParamSpec, TypeVar

__all__ = [
    "WorkerPool",
    "child_pids",
    "end_with_parent",
    "init_worker",
    "interrupts_deferred",
    "sigint_blocked",
    "stop_processes",
]

P = ParamSpec("P")
T = TypeVar("T")

#: How often a worker's watchdog thread checks its parent [s].
PARENT_POLL_S = 0.5

#: How long a stopping pool waits for a terminated worker before it kills it [s].
TERMINATE_GRACE_S = 2.0

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """Hold SIGINT back in this thread, and in the processes and threads it starts meanwhile.

    A SIGINT arriving now is not lost: another thread of the process takes it, or it waits until
    the block is lifted. Does nothing where signal masks do not exist.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # Started later, from within the block, multiprocessing's resource tracker would unblock SIGINT in
    # the thread that starts it (it blocks and then unblocks SIGINT around its own start): start it now.
    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold a Ctrl-C that comes during the block back until its end, then handle it as it would have been.

    In the main thread only (the only one Python runs signal handlers in); elsewhere it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    frames: list[FrameType | None] = []

    def remember(signum: int, frame: FrameType | None) -> None:
        frames.append(frame)

    previous = signal.signal(signal.SIGINT, remember)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if frames and callable(previous):
            previous(signal.SIGINT, frames[-1])


def _arm_pdeathsig() -> bool:
    """Ask Linux to SIGKILL this process when the thread that started it ends; False where it cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return int(libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


def end_with_parent(parent: int, pdeathsig: bool = True) -> None:
    """End this process soon after the process ``parent`` (its parent now) dies, however it dies.

    ``pdeathsig`` arms Linux's parent-death signal as well as the watchdog thread. The kernel sends
    it when the *thread* that started this process ends, so pass it only for a process started by
    its parent's main thread, which lives as long as the parent.
    """
    if pdeathsig:
        _arm_pdeathsig()
    threading.Thread(target=_watch_parent, args=(parent,), name="hitchpark-watch-parent", daemon=True).start()
    if os.getppid() != parent:  # the parent died before the watch began
        os._exit(1)


def init_worker(parent: int) -> None:
    """Initializer of a pool's worker: ignore SIGINT, and end with the process ``parent``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # blocked since its start; now that it is ignored, nothing waits
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    end_with_parent(parent, pdeathsig=bool(getattr(current_process(), "from_main_thread", False)))


class WorkerProcess(SpawnProcess):
    """A spawned process born with SIGINT blocked; it knows whether its parent's main thread started it."""

    from_main_thread = False

    def start(self) -> None:
        self.from_main_thread = threading.current_thread() is threading.main_thread()  # pickled to the child
        # Not cut short by Ctrl-C: a child left without its start-up data prints a traceback, and one
        # started but not yet recorded would not be stopped.
        with interrupts_deferred(), sigint_blocked():
            super().start()


class WorkerContext(SpawnContext):
    """The ``spawn`` start method with :class:`WorkerProcess`; keeps every process it made."""

    def __init__(self) -> None:
        super().__init__()
        self.processes: list[WorkerProcess] = []

    def Process(self, *args: Any, **kwargs: Any) -> WorkerProcess:  # type: ignore[override]
        process = WorkerProcess(*args, **kwargs)
        self.processes.append(process)
        return process


class _Executor(ProcessPoolExecutor):
    """A process pool whose ``submit`` (which may start a worker and the pool's thread) Ctrl-C does not cut short.

    Cut short, it leaves the pool half set up: a thread that cannot be joined, a worker not recorded.
    """

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        with interrupts_deferred():
            return super().submit(fn, *args, **kwargs)


class WorkerPool:
    """A ``concurrent.futures`` process pool of ``workers`` quiet workers that end with this process.

    ``with WorkerPool(n) as pool: pool.submit(...)``. Leaving the block normally waits for the
    submitted tasks; leaving it on an exception (a KeyboardInterrupt, an error of a task) cancels the
    queued tasks, terminates the workers (waiting at most :data:`TERMINATE_GRACE_S` before killing
    them) and returns once they are gone.
    """

    def __init__(self, workers: int):
        self.workers = workers
        self._context: WorkerContext | None = None
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> ProcessPoolExecutor:
        self._context = WorkerContext()
        self._pool = _Executor(
            max_workers=self.workers, mp_context=self._context, initializer=init_worker, initargs=(os.getpid(),)
        )
        return self._pool

    def __exit__(self, *exc: object) -> None:
        pool, context = self._pool, self._context
        self._pool = self._context = None
        if pool is None or context is None:
            return
        if not exc or exc[0] is None:
            pool.shutdown(wait=True)
            return
        stop_processes(context.processes)
        pool.shutdown(wait=True, cancel_futures=True)  # the pool's own thread finds its workers gone and ends


def stop_processes(processes: list[WorkerProcess], grace: float = TERMINATE_GRACE_S) -> None:
    """Terminate the started ``processes`` still running, and the processes they started in turn.

    A worker's own children (the C compiler building a solver, say) would otherwise run on,
    orphaned. A process that has not ended ``grace`` seconds after SIGTERM is killed.
    """
    started = [p for p in processes if p.pid is not None and p.exitcode is None]
    descendants = _descendants({p.pid for p in started if p.pid is not None})
    for p in started:
        p.terminate()
    for pid in descendants:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGTERM)
    # Poll rather than wait on the process sentinels: a worker's orphaned children keep those open.
    deadline = time.monotonic() + grace
    while any(p.exitcode is None for p in started) and time.monotonic() < deadline:
        time.sleep(0.01)
    for p in started:
        if p.exitcode is None:
            p.kill()
            p.join()


def child_pids() -> set[int] | None:
    """The process ids of this process's children now; None where /proc is not there to tell."""
    children = _children_by_parent()
    return None if children is None else set(children.get(os.getpid(), []))


def _descendants(roots: set[int]) -> list[int]:
    """The processes below ``roots`` (children, their children, ...); empty where /proc is not there."""
    children = _children_by_parent() or {}
    found: list[int] = []
    todo = list(roots)
    while todo:
        kids = children.get(todo.pop(), [])
        found.extend(kids)
        todo.extend(kids)
    return found


def _children_by_parent() -> dict[int, list[int]] | None:
    children: dict[int, list[int]] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return None
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="ascii", errors="replace") as fh:
                stat = fh.read()
        except OSError:  # ended meanwhile
            continue
        fields = stat[stat.rfind(")") + 2 :].split()  # after "pid (name)": state, ppid, ...
        if fields and fields[0] != "Z":  # a zombie has ended already
            children.setdefault(int(fields[1]), []).append(int(entry))
    return children
