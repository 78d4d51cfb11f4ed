"""Ctrl-C in the main process of a command: one KeyboardInterrupt that reaches the command, then quiet.

Python turns SIGINT into a KeyboardInterrupt, but two things get in its way here:

- CasADi's solvers check for Ctrl-C themselves while they iterate. They run Python's handler,
  catch the KeyboardInterrupt it raises, end the solve as a failure and carry on (the NMPC then
  tries its fallback solver and the maneuver goes on). When the signal comes while CasADi runs,
  :class:`Interrupts` raises the KeyboardInterrupt only once CasADi has returned to Python, at the
  next bytecode, where nothing swallows it.
- A second Ctrl-C (a user pressing twice) would cut short the cleanup of the first: stopping the
  workers, removing a half-built output folder. While a KeyboardInterrupt is being handled, a
  SIGINT is ignored.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
from types import FrameType
from typing import Any

__all__ = ["Interrupts", "caused_by_interrupt"]


def _casadi_dir() -> str | None:
    module = sys.modules.get("casadi")
    path = getattr(module, "__file__", None)
    return os.path.dirname(path) + os.sep if path else None


def _raise_in(thread_id: int) -> None:
    """Raise KeyboardInterrupt in the thread ``thread_id`` when it next runs Python bytecode (not in C code)."""
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread_id), ctypes.py_object(KeyboardInterrupt))


def caused_by_interrupt(exc: BaseException | None) -> bool:
    """Whether ``exc`` is a KeyboardInterrupt or was raised because of one.

    A KeyboardInterrupt that lands inside a Python method called from C code (NumPy converting a
    CasADi matrix, say) reaches the caller as a ``SystemError`` whose cause is the interrupt.
    """
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _handling_interrupt(thread_id: int) -> bool:
    """Whether the thread ``thread_id`` handles a KeyboardInterrupt now (in ``except``, ``finally``, ``__exit__``)."""
    current = sys._current_exceptions().get(thread_id)
    value = current[1] if isinstance(current, tuple) else current  # a tuple up to Python 3.11
    return caused_by_interrupt(value)


class Interrupts:
    """The SIGINT handler of a command, installed for the lifetime of the object.

    Installed only in the main thread and only over Python's own handler (so a caller's handler,
    or a SIGINT ignored from the start, is left alone). :meth:`exiting` ignores SIGINT from then on,
    for the process's last moments after an interrupt; :meth:`restore` puts the previous handler back.

    After a SIGINT a watcher thread makes sure the KeyboardInterrupt arrives: whenever the main
    thread is found not handling one (CasADi swallowed it, or the signal came during a solve and was
    left to it), it raises one there, every :data:`RETRY_S` seconds, until :meth:`exiting` or
    :meth:`restore`.
    """

    #: How soon the watcher raises an interrupt left to it, and how often it raises a lost one again [s].
    FIRST_S = 0.02
    RETRY_S = 0.25

    def __init__(self) -> None:
        self.seen = False
        self.installed = False
        self._previous: Any = None
        self._main = threading.get_ident()
        self._done = threading.Event()
        self._watcher: threading.Thread | None = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.getsignal(signal.SIGINT)
            if previous is signal.default_int_handler:
                self._previous = previous
                signal.signal(signal.SIGINT, self._handle)
                self.installed = True

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if isinstance(sys.exc_info()[1], KeyboardInterrupt):
            return  # an earlier one is being cleaned up after: let that finish
        self.seen = True
        casadi = _casadi_dir()
        in_casadi = frame is not None and casadi is not None and frame.f_code.co_filename.startswith(casadi)
        if self._watcher is None:
            self._watcher = threading.Thread(
                target=self._watch, args=(self.FIRST_S if in_casadi else self.RETRY_S,), daemon=True
            )
            self._watcher.start()
        if in_casadi:
            return  # CasADi would print it and swallow it: the watcher raises it once CasADi has returned
        raise KeyboardInterrupt

    def _watch(self, delay: float) -> None:
        # Holding the GIL, CasADi keeps this thread waiting until it returns to Python.
        while not self._done.wait(delay):
            if not _handling_interrupt(self._main):
                _raise_in(self._main)
            delay = self.RETRY_S

    def exiting(self) -> None:
        """The command ends on an interrupt: ignore further SIGINTs while the process shuts down."""
        self._done.set()
        if self.installed:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            self.installed = False

    def restore(self) -> None:
        """Put the previous handler back (if this one is still installed)."""
        self._done.set()
        if self.installed:
            signal.signal(signal.SIGINT, self._previous)
            self.installed = False
