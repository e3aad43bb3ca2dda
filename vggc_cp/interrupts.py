"""Ctrl-C, SIGTERM and SIGHUP end a command within a second or two, leaving no temporary file.

:func:`guard` is held by :func:`vggc_cp.cli.main` around a command:

* the handler (main thread) removes the temporary files of writes in progress
  (:func:`vggc_cp.safeio.cleanup_temps`), prints one line, and raises ``KeyboardInterrupt``
  (SIGINT) or ``SystemExit(128 + signum)`` so ``finally`` blocks unwind the command;
* a watchdog thread learns of the signal from the C-level handler at once (a wake-up socket,
  :func:`signal.set_wakeup_fd`), whatever the main thread is doing -- waiting for a thread pool
  of Sinkhorn workers, or inside a long C call (CP-SAT) where no Python handler can run. If the
  process has not ended :data:`GRACE_SECONDS` later, it removes the temporary files again,
  terminates the worker processes and ends the process with ``os._exit(128 + signum)``;
* a forked worker process (``ProcessPoolExecutor``) that gets the signal removes its own
  temporary files and ends at once.

The exit code is 130 (SIGINT), 143 (SIGTERM) or 129 (SIGHUP) whatever code catches the
exception on the way: :func:`received` tells :func:`vggc_cp.cli.main` a signal came, so none
is swallowed.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import socket
import sys
import threading
from collections.abc import Iterator

from vggc_cp.safeio import cleanup_temps

#: the signals that end a command
SIGNALS = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None))
                if s is not None)
#: seconds the command has to unwind after a signal before the watchdog ends the process
GRACE_SECONDS = 0.5

_state = {"received": None, "said": False, "pid": os.getpid(), "deferred": 0}
_lock = threading.Lock()
_wakeup: dict[str, socket.socket] = {}


def received() -> int | None:
    """The first signal received while :func:`guard` was held (None: none)."""
    return _state["received"]


def exit_code(signum: int) -> int:
    return 128 + int(signum)


def announce(signum: int) -> None:
    """The one stderr line of an interrupted run (printed once)."""
    with _lock:
        if _state["said"]:
            return
        _state["said"] = True
    text = ("interrupted" if signum == signal.SIGINT
            else f"terminated by signal {int(signum)}")
    with contextlib.suppress(Exception):
        print(f"vggc-cp: {text}", file=sys.stderr, flush=True)


def _handler(signum, _frame):
    if os.getpid() != _state["pid"]:  # a forked worker: its temporary files, then out
        cleanup_temps()
        os._exit(exit_code(signum))
    if _state["received"] is None:
        _state["received"] = signum
    cleanup_temps()
    announce(_state["received"])
    if _state["deferred"]:  # raised when the block ends (the watchdog still ends the run)
        return
    _raise(signum)


def _raise(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SystemExit(exit_code(signum))


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A block a signal must not interrupt halfway (importing torch: a KeyboardInterrupt
    inside its initialisation aborts the process, exit -6): the signal is recorded and
    announced at once, and its exception raised when the block ends; the watchdog still ends
    the run :data:`GRACE_SECONDS` after the signal if the block lasts longer."""
    _state["deferred"] += 1
    try:
        yield
    finally:
        _state["deferred"] -= 1
    if not _state["deferred"] and _state["received"] is not None \
            and os.getpid() == _state["pid"]:
        _raise(_state["received"])


def _worker_exit(signum, _frame):
    cleanup_temps()
    os._exit(exit_code(signum))


def worker_signals() -> None:
    """Initializer of a worker process: SIGINT, SIGTERM and SIGHUP remove the worker's own
    temporary files and end it at once (no traceback of a worker idle in its queue)."""
    for sig in SIGNALS:
        with contextlib.suppress(ValueError, OSError):
            signal.signal(sig, _worker_exit)


#: seconds worker processes have to stop as a Ctrl-C stops them before they are terminated
CHILD_GRACE = 0.4


def end_children(grace: float = CHILD_GRACE) -> None:
    """Stop every worker process: first as a Ctrl-C does (``SIGINT``: a write in progress
    removes its temporary file on the way out), then, ``grace`` seconds later, terminate the
    ones still running."""
    import time

    with contextlib.suppress(Exception):
        children = multiprocessing.active_children()
        for child in children:
            with contextlib.suppress(OSError, TypeError):
                os.kill(child.pid, signal.SIGINT)
        deadline = time.monotonic() + grace
        for child in children:
            child.join(max(deadline - time.monotonic(), 0.0))
        for child in children:
            if child.is_alive():
                child.terminate()


def _finish(signum: int) -> None:
    """End the process now: temporary files, worker processes, then ``os._exit``."""
    if _state["received"] is None:
        _state["received"] = signum
    cleanup_temps()
    announce(_state["received"])
    end_children()
    cleanup_temps()
    with contextlib.suppress(Exception):
        sys.stderr.flush()
        sys.stdout.flush()
    os._exit(exit_code(_state["received"]))


def _watch(sock: socket.socket) -> None:
    """The watchdog thread: a signal byte on the wake-up socket arms the grace deadline."""
    import time

    deadline = None
    while True:
        timeout = None if deadline is None else max(deadline - time.monotonic(), 0.0)
        sock.settimeout(timeout)
        try:
            data = sock.recv(64)
        except TimeoutError:
            _finish(_state["received"] or signal.SIGTERM)
            return
        except OSError:
            return
        if not data:
            return
        if os.getpid() != _state["pid"]:
            return
        if deadline is None and any(b in SIGNALS for b in data):
            signum = next(b for b in data if b in SIGNALS)
            if _state["received"] is None:
                _state["received"] = signal.Signals(signum)
            deadline = time.monotonic() + GRACE_SECONDS


def _ensure_watchdog() -> socket.socket:
    """The write end of the wake-up socket; its watchdog thread started once per process."""
    if "w" not in _wakeup or _state["pid"] != os.getpid():
        r, w = socket.socketpair()
        w.setblocking(False)
        _wakeup.update(r=r, w=w)
        _state["pid"] = os.getpid()
        threading.Thread(target=_watch, args=(r,), name="vggc-cp-signals", daemon=True).start()
    return _wakeup["w"]


def _in_child() -> None:
    """After a fork: the child's own signals never reach the parent's watchdog."""
    with contextlib.suppress(ValueError, OSError):
        signal.set_wakeup_fd(-1)


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_in_child)


@contextlib.contextmanager
def guard() -> Iterator[None]:
    """Install the handlers of :data:`SIGNALS` and the watchdog for the ``with`` block (main
    thread only; elsewhere nothing changes). Restores the previous handlers on exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _state.update(received=None, said=False, pid=os.getpid())
    w = _ensure_watchdog()
    saved = {sig: signal.signal(sig, _handler) for sig in SIGNALS}
    old_fd = signal.set_wakeup_fd(w.fileno(), warn_on_full_buffer=False)
    try:
        yield
    finally:
        signal.set_wakeup_fd(old_fd)
        for sig, handler in saved.items():
            signal.signal(sig, handler)


__all__ = ["GRACE_SECONDS", "SIGNALS", "announce", "exit_code", "guard", "received"]
