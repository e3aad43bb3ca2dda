"""Where independent tasks run: in this process, in local worker processes, or on a cluster.

One small execution layer for every fan-out of the package: the cells of a ``(k_pick,
k_place)`` grid sweep (:mod:`vggc_cp.solvers.sweep`), the waves of CP-SAT cells of an exact
sweep (:mod:`vggc_cp.solvers.cpsat.frontier`), the row blocks of the pairwise distances
(:mod:`vggc_cp.vision.distances`) and the cells of the Table-1 runner and the robustness study
(:mod:`vggc_cp.experiments`).

Backends (:data:`BACKENDS`):

* ``local`` (default): ``jobs == 1`` runs every task in this process, in order; ``jobs > 1``
  runs them in that many local worker processes (forked where the platform can).
* ``dask``: a :class:`distributed.Client` on the scheduler at ``scheduler`` (e.g.
  ``tcp://host:8786``; default ``$VGGC_CP_SCHEDULER``), or on a fresh
  :class:`distributed.LocalCluster` of ``jobs`` single-threaded workers when no address is set.
  Needs the ``cluster`` extra (``pip install 'vggc-cp[cluster]'``).
* ``ray``: ``ray.init(address=scheduler)`` (a local ray when no address is set). Needs
  ``pip install ray``.

Tasks are ``fn(item)`` for a module-level ``fn`` and picklable items; results come back in the
items' order, so a run gives the same results on every backend. Progress callbacks run here,
never on a worker.
"""

from __future__ import annotations

import contextlib
import ipaddress
import multiprocessing
import os
import re
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

from vggc_cp.errors import VggcError, lookup

BACKENDS = ("local", "dask", "ray")
#: Environment variable holding the default scheduler address of ``dask`` / ``ray``.
SCHEDULER_ENV = "VGGC_CP_SCHEDULER"
LOCAL = "local"
#: URL schemes of a dask scheduler address this tool connects to (``host:port`` means tcp)
DASK_SCHEMES = ("tcp", "tls")
#: Longest address accepted (a host name is at most 253 characters)
MAX_ADDRESS = 300
_HOST_RE = re.compile(r"(?=.{1,253}$)[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
                      r"(?:\.[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*")


def parse_address(text: str, backend: str, source: str = "--scheduler") -> str:
    """The scheduler address ``text`` checked for its shape before dask or ray sees it.

    dask: ``tcp://HOST:PORT``, ``tls://HOST:PORT`` or ``HOST:PORT`` (read as tcp); ray:
    ``auto``, ``ray://HOST:PORT`` or ``HOST:PORT``. HOST is a host name, an IPv4 address or an
    IPv6 address in brackets; PORT is 1..65535. dask's in-process address of a cluster in this
    very process (``inproc://HOST/PID/N``, what ``LocalCluster(processes=False)`` gives a
    notebook or a test) is taken as it is. Anything else (``inproc://x``, ``udp://``,
    ``http://``, a path, a missing port, control characters) is refused naming ``source``.

    Returns
    -------
    str
        The address as the backend's client takes it (``tcp://`` added to a bare dask one).
    """
    shown = text if len(text) <= 60 else text[:60] + "..."

    def bad(why: str) -> VggcError:
        return VggcError(f"{source} {shown!r}: {why}")

    if len(text) > MAX_ADDRESS:
        raise bad(f"longer than {MAX_ADDRESS} characters")
    if not text.isprintable() or any(c.isspace() for c in text):
        raise bad("holds spaces or control characters")
    allowed = DASK_SCHEMES if backend == "dask" else ("ray",)
    if backend == "ray" and text == "auto":
        return text
    if backend == "dask" and re.fullmatch(r"inproc://[A-Za-z0-9.\-]+/[0-9]{1,10}/[0-9]{1,10}",
                                          text):
        return text
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = (allowed[0], text)
    if scheme not in allowed:
        raise bad(f"expected {' or '.join(s + '://HOST:PORT' for s in allowed)} "
                  f"(or HOST:PORT) for --backend {backend}")
    m = re.fullmatch(r"(\[[^\]]*\]|[^:/\[\]]+):([0-9]{1,5})", rest)
    if m is None:
        raise bad("expected HOST:PORT after the scheme (an IPv6 host in brackets)")
    host, port = m.group(1), int(m.group(2))
    if not 1 <= port <= 65535:
        raise bad(f"port {port} is not in 1..65535")
    if host.startswith("["):
        try:
            ipaddress.IPv6Address(host[1:-1])
        except ValueError:
            raise bad(f"{host} is not an IPv6 address") from None
    elif not _HOST_RE.fullmatch(host):
        raise bad(f"{host!r} is not a host name or IPv4 address")
    if backend == "dask" and not sep:
        return f"tcp://{text}"
    return text


@dataclass(frozen=True)
class Backend:
    """Where tasks run.

    Attributes
    ----------
    name : str
        ``local``, ``dask`` or ``ray``.
    scheduler : str or None
        Address of an existing dask scheduler or ray cluster; None: ``$VGGC_CP_SCHEDULER``,
        else a fresh local cluster. Refused with ``local``.
    jobs : int or None
        ``local``: worker processes (1 or None: in this process); a fresh dask
        ``LocalCluster``: its workers (None: dask's default, one per core). An existing
        cluster decides its own parallelism.
    processes : bool
        A fresh dask ``LocalCluster`` runs its workers as processes (True) or threads.
    start : str or None
        Start method of local worker processes (``fork``, ``spawn``, ``forkserver``); None:
        ``fork`` where the platform has it.
    """

    name: str = LOCAL
    scheduler: str | None = None
    jobs: int | None = 1
    processes: bool = True
    start: str | None = None

    def __post_init__(self) -> None:
        lookup({b: b for b in BACKENDS}, self.name, "backend")
        if self.jobs is not None and self.jobs < 1:
            raise VggcError(f"--jobs must be at least 1, got {self.jobs}")
        if self.name == LOCAL and self.scheduler:
            raise VggcError("--scheduler applies to --backend dask or ray, not local")
        self.address  # noqa: B018 - --scheduler / $VGGC_CP_SCHEDULER checked here, once

    @property
    def address(self) -> str | None:
        """``scheduler``, else ``$VGGC_CP_SCHEDULER`` (None for ``local`` or when neither)."""
        if self.name == LOCAL:
            return None
        if self.scheduler:
            return parse_address(self.scheduler, self.name)
        env = os.environ.get(SCHEDULER_ENV, "").strip()
        return parse_address(env, self.name, f"${SCHEDULER_ENV}") if env else None

    @property
    def remote(self) -> bool:
        """Whether tasks leave this process."""
        return self.name != LOCAL or (self.jobs or 1) > 1


# ---------------------------------------------------------------- executors


class Executor:
    """Runs ``fn(item)`` for many items (the in-process executor; the base of the others)."""

    name = LOCAL
    #: Whether tasks run in this process (callbacks can be handed to them).
    inline = True

    def completed(self, fn: Callable, items: Sequence) -> Iterator[tuple[int, object]]:
        """``(index, fn(items[index]))`` for every item, as each finishes."""
        for i, item in enumerate(items):
            yield i, fn(item)

    def map(self, fn: Callable, items: Sequence,
            on_result: Callable[[int, object], None] | None = None) -> list:
        """``[fn(x) for x in items]``, in the items' order; ``on_result(index, result)`` is
        called here as each task finishes (progress bars)."""
        out: list = [None] * len(items)
        for i, res in self.completed(fn, items):
            out[i] = res
            if on_result is not None:
                on_result(i, res)
        return out


class ProcessExecutor(Executor):
    """Local worker processes (forked where the platform can, else spawned)."""

    inline = False

    def __init__(self, jobs: int, start: str | None = None):
        self.jobs = jobs
        self.start = start

    def completed(self, fn, items):
        if not items:
            return
        methods = multiprocessing.get_all_start_methods()
        ctx = multiprocessing.get_context(self.start or ("fork" if "fork" in methods
                                                         else "spawn"))
        from vggc_cp.interrupts import worker_signals

        with ProcessPoolExecutor(max_workers=min(self.jobs, len(items)), mp_context=ctx,
                                 initializer=worker_signals) as pool:
            futures = {pool.submit(fn, item): i for i, item in enumerate(items)}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()


class DaskExecutor(Executor):
    """Tasks on a :class:`distributed.Client`."""

    name = "dask"
    inline = False

    def __init__(self, client):
        self.client = client

    def completed(self, fn, items):
        if not items:
            return
        from distributed import as_completed as dask_completed

        futures = self.client.map(fn, list(items), pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in dask_completed(futures):
            yield index[fut.key], fut.result()


class RayExecutor(Executor):
    """Tasks as ray remote functions."""

    name = "ray"
    inline = False

    def completed(self, fn, items):
        import ray

        remote = ray.remote(fn)
        refs = [remote.remote(item) for item in items]
        index = {ref: i for i, ref in enumerate(refs)}
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield index[done[0]], ray.get(done[0])


def _missing(backend: str, hint: str) -> VggcError:
    return VggcError(f"--backend {backend} is not installed: {hint}")


def check_backend(backend: Backend | str) -> None:
    """Raise :class:`VggcError` saying how to install the backend's package when it is
    missing (before any work)."""
    import importlib.util

    name = backend.name if isinstance(backend, Backend) else backend
    need = {"dask": ("distributed", "pip install 'vggc-cp[cluster]' (or 'dask[distributed]')"),
            "ray": ("ray", "pip install ray")}
    if name in need and importlib.util.find_spec(need[name][0]) is None:
        raise _missing(name, need[name][1])


@contextlib.contextmanager
def open_executor(backend: Backend | None = None) -> Iterator[Executor]:
    """The executor of ``backend`` (default: local, in this process), held open for the
    ``with`` block: a dask client (and the ``LocalCluster`` it started) or a ray session is
    closed on exit; an existing cluster is left running."""
    backend = backend or Backend()
    check_backend(backend)
    if backend.name == LOCAL:
        jobs = backend.jobs or 1
        yield Executor() if jobs == 1 else ProcessExecutor(jobs, backend.start)
        return
    if backend.name == "dask":
        from distributed import Client, LocalCluster

        address = backend.address
        if address:
            try:
                client = Client(address, timeout="10s")
            except (OSError, ValueError, TypeError, MemoryError, OverflowError) as exc:
                # a server that is not a dask scheduler can make dask's comm misread a frame
                # length (an allocation of exabytes): any failure to connect is one line
                why = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
                raise VggcError(f"--scheduler {address}: cannot reach a dask scheduler "
                                f"there ({why})") from None
            try:
                yield DaskExecutor(client)
            finally:
                client.close()
            return
        with LocalCluster(n_workers=backend.jobs, threads_per_worker=1,
                          processes=backend.processes, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            yield DaskExecutor(client)
        return
    import ray

    address = backend.address
    ray.init(address=address, ignore_reinit_error=True)
    try:
        yield RayExecutor()
    finally:
        ray.shutdown()


__all__ = ["BACKENDS", "SCHEDULER_ENV", "parse_address", "Backend", "DaskExecutor", "Executor",
           "ProcessExecutor", "RayExecutor", "check_backend", "open_executor"]
