"""Run work units in parallel: local worker processes or a Ray cluster — the one worker backend
of every parallel job (``scenes``, ``paths``, ``generate``, ``rerender``, ``export``, ``evaluate``).

Both backends take units lazily from an iterator (so the caller can stop feeding them, e.g. once
``target_episodes`` is reached) and yield ``(unit, result)`` as units finish, in completion order.
Results never depend on which worker ran a unit. The iterator may yield :data:`WAIT` while units run:
no unit is ready until a result is in. :class:`Feed` is such an iterator: a queue its caller adds to as
results come in (the next unit of a chain asked as soon as its last one is done), run in one pool.

Local workers are started with the ``spawn`` method: a forked child would inherit the parent's
GL/EGL state. Ray tasks run the same functions; on a multi-machine cluster the output directory must
be on a file system every node can write (workers write their episode files themselves).
"""

from __future__ import annotations

import ctypes
import heapq
import os
import signal
import socket
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Any

from samplehd.errors import ConfigError, require_extra

__all__ = ["BACKENDS", "WAIT", "Backend", "Feed", "default_workers", "keep_freed_memory"]

BACKENDS = ("local", "ray")


class _Wait:
    def __repr__(self) -> str:
        return "WAIT"


# Yielded by a unit iterator instead of a unit: none is ready before a running unit's result is in.
WAIT: Any = _Wait()


def default_workers() -> int:
    """All cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class Backend:
    """Where units run.

    Attributes:
        kind: ``local`` or ``ray``.
        workers: local worker processes (1: in this process), or Ray CPUs to start a local Ray with.
        ray_address: address of a running Ray cluster (``auto``, ``ray://host:10001``); None starts or
            reuses a local Ray instance.
    """

    kind: str = "local"
    workers: int = 1
    ray_address: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in BACKENDS:
            raise ConfigError(f"backend={self.kind!r}: valid: {', '.join(BACKENDS)}", field="backend")
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ConfigError(f"workers={self.workers!r}: must be an integer ≥ 1", field="workers")
        if self.ray_address is not None and self.kind != "ray":
            raise ConfigError(f"ray_address={self.ray_address!r}: only used with `backend` ray (the {self.kind} "
                              f"backend ignores it); add `backend` ray or leave it out",
                              field="ray_address")
        if self.kind == "ray" and self.ray_address is not None:
            check_ray_address(self.ray_address)

    def connect(self) -> None:
        """Join the Ray cluster now (a no-op for the local backend), so that an address nothing serves
        is refused before a command writes anything, not after it has started.

        Raises:
            ConfigError: one line naming the address (Ray's own traceback dropped).
        """
        if self.kind == "ray":
            _ray_init(self.workers, self.ray_address)

    def describe(self) -> str:
        if self.kind == "ray":
            return f"ray ({self.ray_address or 'local'})"
        return f"local, {self.workers} worker{'s' if self.workers > 1 else ''}"

    def map(self, fn: Callable[[Any], Any], units: Iterable[Any]) -> Iterator[tuple[Any, Any]]:
        """Run ``fn`` on every unit; yield ``(unit, result)`` as they finish.

        ``fn`` must be a module-level function (workers import it by name). Units are taken lazily.
        The first exception raised by a unit stops the run: pending units are cancelled and the
        exception is re-raised here.
        """
        units = iter(units)
        if self.kind == "ray":
            yield from _ray_map(fn, units, self.workers, self.ray_address)
        elif self.workers <= 1:
            keep_freed_memory()
            for unit in units:
                if unit is WAIT:  # nothing runs here between two units: nothing to wait for
                    raise RuntimeError(_WAITING_IDLE)
                yield unit, fn(unit)
        else:
            yield from _pool_map(fn, units, self.workers)


_WAITING_IDLE = "the unit iterator waits for a result while no unit runs"


class Feed:
    """Units a caller adds to while their results come in, run on one backend (one pool for all).

    ``run`` yields ``(unit, result)`` as units finish; between two results the caller may ``put`` new
    units (e.g. the next step of the chain a result ends), and the run ends when nothing is queued or
    running. Of the queued units the lowest ``priority`` starts first, then the earliest put.
    """

    def __init__(self) -> None:
        self._queue: list[tuple[float, int, Any]] = []
        self._put = 0
        self._running = 0

    def put(self, unit: Any, priority: float = 0) -> None:
        heapq.heappush(self._queue, (priority, self._put, unit))
        self._put += 1

    def _units(self) -> Iterator[Any]:
        while self._queue or self._running:
            if not self._queue:
                yield WAIT
                continue
            self._running += 1
            yield heapq.heappop(self._queue)[2]

    def run(self, backend: Backend, fn: Callable[[Any], Any]) -> Iterator[tuple[Any, Any]]:
        """Run ``fn`` on the queued units and on those put while it runs (see :meth:`Backend.map`)."""
        for unit, result in backend.map(fn, self._units()):
            self._running -= 1
            yield unit, result


def _die_with_parent() -> None:
    """Worker initializer: on Linux, get SIGKILL when the coordinating process dies (killed or
    terminated), so no orphaned worker keeps writing into the dataset; and keep freed memory."""
    keep_freed_memory()
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except OSError:
        pass


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters


def keep_freed_memory() -> None:
    """Let this process reuse the memory its work units free instead of handing it back to the system.

    An episode with images allocates tens of MB of deflated frames and file buffer and frees them at its
    end; glibc returns such blocks to the system, and the next episode faults fresh pages in again, which
    costs CPU (most on virtual machines: measured 0.2 CPU ms per 640x360 frame). Blocks up to 256 MB now
    come from the heap, and the heap keeps up to 1 GB free for the next unit. glibc on Linux only.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, 256 << 20)
        libc.mallopt(_M_TRIM_THRESHOLD, 1 << 30)
    except (OSError, AttributeError):  # another C library: its defaults stay
        pass


# One worker per core: BLAS thread pools inside each worker would oversubscribe the cores, and
# OpenBLAS's spinning threads then cost more than they save (measured: 2 workers 0.6× the frames/s of 1
# with default threads, 2.2× with one thread each).
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _pool_map(fn: Callable[[Any], Any], units: Iterator[Any], workers: int) -> Iterator[tuple[Any, Any]]:
    window = 2 * workers
    for var in _THREAD_VARS:  # inherited by the spawned workers; a user's setting is kept
        os.environ.setdefault(var, "1")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=_die_with_parent)
    pending: dict[Future, Any] = {}
    try:
        yield from _windowed(units, window, pending, lambda unit: pool.submit(fn, unit),
                             lambda handles: wait(handles, return_when=FIRST_COMPLETED)[0],
                             lambda fut: fut.result())
    except KeyboardInterrupt:
        # Ctrl-C reaches the workers too, but a SIGTERM (samplehd.commands' sigterm_as_interrupt) only
        # this process: stop the units in flight rather than wait for them, as an interrupted run is
        # resumed from its finished units anyway.
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            process.terminate()
        raise
    finally:
        for fut in pending:
            fut.cancel()
        pool.shutdown(wait=True, cancel_futures=True)


def _windowed(
    units: Iterator[Any],
    window: int,
    pending: dict[Any, Any],
    submit: Callable[[Any], Any],
    wait_done: Callable[[list[Any]], Any],
    result_of: Callable[[Any], Any],
) -> Iterator[tuple[Any, Any]]:
    """Keep at most `window` units in flight; yield (unit, result) as they finish. A :data:`WAIT` from
    `units` stops the submitting until a result is in.

    `pending` maps in-flight handles to units and is the caller's, so it can cancel them on exit.
    """
    exhausted = False
    while True:
        while not exhausted and len(pending) < window:
            try:
                unit = next(units)
            except StopIteration:
                exhausted = True
                break
            if unit is WAIT:
                if not pending:
                    raise RuntimeError(_WAITING_IDLE)
                break
            pending[submit(unit)] = unit
        if not pending:
            return
        for handle in wait_done(list(pending)):
            unit = pending.pop(handle)
            yield unit, result_of(handle)


# How long to wait for a Ray cluster's address to answer before refusing it [s].
RAY_CONNECT_TIMEOUT = 5.0


def check_ray_address(address: str, timeout: float = RAY_CONNECT_TIMEOUT) -> None:
    """Refuse a Ray address nothing answers at, within ``timeout`` seconds, before any work starts
    (``ray.init`` would otherwise wait for minutes). ``auto`` (a cluster started on this machine) is
    left to Ray.

    Raises:
        ConfigError: a malformed address, or no answer (one line naming the address).
    """
    if address in ("auto", "local"):
        return
    host, _, port = address.split("://", 1)[-1].rpartition(":")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"ray_address={address!r}: expected HOST:PORT, ray://HOST:PORT or auto", field="ray_address")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout) as conn:
            conn.settimeout(timeout)
            grpc = _speaks_grpc(conn)
    except OSError as exc:
        reason = "no answer" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc) or type(exc).__name__)
        raise ConfigError(f"ray_address={address!r}: nothing answers there within {timeout:g} s ({reason}); "
                          f"start the cluster (ray start --head) or fix the address", field="ray_address") from None
    if not grpc:
        raise ConfigError(f"ray_address={address!r}: something listens there but it is not a Ray cluster (no gRPC "
                          f"answer within {timeout:g} s); give the address `ray start --head` printed",
                          field="ray_address")


# The HTTP/2 client preface and an empty SETTINGS frame: every gRPC server (Ray's GCS and Ray Client
# both are) answers with a SETTINGS frame of its own.
_HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])


def _speaks_grpc(conn: socket.socket) -> bool:
    """Whether the peer answers the HTTP/2 preface with a SETTINGS frame (a gRPC server does);
    a listener that says something else, closes, or stays silent until the timeout does not."""
    try:
        conn.sendall(_HTTP2_PREFACE)
        head = b""
        while len(head) < 9:
            chunk = conn.recv(9 - len(head))
            if not chunk:
                return False
            head += chunk
    except OSError:
        return False
    return head[3] == 0x04  # frame type SETTINGS


def _ray_init(workers: int, address: str | None) -> Any:
    """The ray module, initialised once per process (a cluster at ``address``, or a local one)."""
    ray = require_extra("ray", "ray", "`backend` ray")
    if not ray.is_initialized():
        # Ray's core logs each failed connection attempt to file descriptor 2 itself: hold those lines
        # back, show them if it joins, and let a failure be our one line.
        with tempfile.TemporaryFile() as held:
            sys.stderr.flush()
            saved = os.dup(2)
            os.dup2(held.fileno(), 2)
            try:
                if address:
                    ray.init(address=address, include_dashboard=False, log_to_driver=False)
                else:
                    ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                raise ConfigError(f"ray_address={address or '(local)'}: Ray could not start or join the cluster "
                                  f"({reason[:160]}); start it (ray start --head) or fix the address",
                                  field="ray_address") from None
            finally:
                sys.stderr.flush()
                os.dup2(saved, 2)
                os.close(saved)
            held.seek(0)
            sys.stderr.write(held.read().decode(errors="replace"))
    return ray


def _ray_map(fn: Callable[[Any], Any], units: Iterator[Any], workers: int,
             address: str | None) -> Iterator[tuple[Any, Any]]:
    ray = _ray_init(workers, address)
    remote = ray.remote(num_cpus=1, max_retries=0)(fn)
    window = max(2, 2 * int(ray.cluster_resources().get("CPU", workers)))
    def result_of(ref: Any) -> Any:
        try:
            return ray.get(ref)
        except ray.exceptions.RayTaskError as exc:
            cause = exc.as_instanceof_cause()
            raise (cause.cause if getattr(cause, "cause", None) else cause) from None

    pending: dict[Any, Any] = {}
    try:
        yield from _windowed(units, window, pending, remote.remote,
                             lambda handles: ray.wait(handles, num_returns=1)[0], result_of)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
