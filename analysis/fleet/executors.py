"""Where a fleet's jobs run: in this process, in a local process pool, or as Ray tasks.

Every executor has the same small interface — ``slots`` (jobs it takes at once), ``submit(key, fn,
job)``, ``wait()`` (at least one finished job: ``(key, result)``, or ``(key, Lost(reason))`` when the
process running it died) and ``close(cancel=...)`` — and ``run_jobs`` drives any of them, retrying
lost and transient jobs. A job's result depends only on the job, so every executor gives the same
results.

- ``InProcess``: one job at a time, here.
- ``ProcessPool``: ``workers`` worker processes started with ``spawn`` (never ``fork``: the parent
  may hold threads). Each worker is a one-process ``concurrent.futures`` pool holding one job at a
  time, so when a process dies (kill -9, the OOM killer) the one job it ran is the one lost, and
  only that worker is restarted. Each worker runs the numeric libraries' thread pools on one
  thread (``OMP_NUM_THREADS=1``, ... unless set), so N workers fill N cores, as Ray does for its
  tasks. Workers ignore Ctrl-C while idle and stop the job they run on it
  (the replay removes its temporary folder), so an interrupted fleet leaves no half-written output.
- ``RayPool``: each job a Ray task with a CPU (and optionally memory) request. Ray runs on a local
  instance started here (``address=None``: bound to 127.0.0.1, no dashboard, shut down on close) or
  on a cluster (``address="auto"``, ``"HOST:6379"`` or ``"ray://HOST:10001"``); Ray itself is
  imported only here (``pip install navlog[fleet]``). ``start_local_ray`` starts the local instance.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor
from concurrent.futures import wait as wait_futures
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Protocol

from navlog.errors import ConfigError, Terminated

__all__ = ["Executor", "InProcess", "Lost", "ProcessPool", "RayPool", "import_ray", "run_jobs", "start_local_ray"]

RAY_LOCAL_ONLY = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"  # "0": a single-machine Ray on the loopback address
CANCEL_WAIT_S = 30.0  # how long a cancelled Ray task gets to clean up before Ray shuts down
RAY_MISSING = "--ray needs Ray, which is not installed: pip install navlog[fleet]"


@dataclass(frozen=True)
class Lost:
    """A job whose process died before it returned (killed, out of memory, crashed)."""

    reason: str


class Executor(Protocol):
    name: str
    slots: int

    def submit(self, key: int, fn: Callable[[Any], Any], job: Any) -> None: ...

    def wait(self) -> list[tuple[int, Any]]: ...

    def close(self, *, cancel: bool = False, interrupt: bool = False) -> None: ...


def run_jobs(
    executor: Executor,
    fn: Callable[[Any], Any],
    jobs: Sequence[Any],
    *,
    retries: int = 0,
    retryable: Callable[[Any], bool] = lambda result: False,
    on_done: Callable[[int, Any, int], None] = lambda key, result, attempts: None,
) -> list[tuple[Any, int]]:
    """Run ``fn(job)`` for every job on ``executor``; ``(result or Lost, attempts)`` in job order.

    A lost job, or one whose result is ``retryable``, runs again up to ``retries`` more times.
    ``on_done(index, result, attempts)`` is called as each job finishes for good. On an exception
    (Ctrl-C) the executor's jobs are cancelled before it propagates.
    """
    pending = deque(range(len(jobs)))
    attempts = [0] * len(jobs)
    results: list[tuple[Any, int]] = [(None, 0)] * len(jobs)
    running = 0
    try:
        while pending or running:
            while pending and running < executor.slots:
                i = pending.popleft()
                attempts[i] += 1
                executor.submit(i, fn, jobs[i])
                running += 1
            for i, result in executor.wait():
                running -= 1
                if (isinstance(result, Lost) or retryable(result)) and attempts[i] <= retries:
                    pending.append(i)
                    continue
                results[i] = (result, attempts[i])
                on_done(i, result, attempts[i])
    except BaseException as exc:  # (SIGTERM reached this process alone: its workers' jobs are interrupted)
        executor.close(cancel=True, interrupt=isinstance(exc, Terminated))
        raise
    executor.close()
    return results


@dataclass(frozen=True)
class Spent:
    """A job's result from a worker process it left unsound (a wall-time limit interrupted it anywhere, say in
    the middle of an import): the pool hands on ``value`` and ends that process; the next job gets a new one."""

    value: Any


def _unwrap(result: Any) -> Any:
    return result.value if isinstance(result, Spent) else result


class InProcess:
    """Runs each job in this process when ``wait`` is called."""

    name = "this process"
    slots = 1

    def __init__(self) -> None:
        self._queue: deque[tuple[int, Callable[[Any], Any], Any]] = deque()

    def submit(self, key: int, fn: Callable[[Any], Any], job: Any) -> None:
        self._queue.append((key, fn, job))

    def wait(self) -> list[tuple[int, Any]]:
        key, fn, job = self._queue.popleft()
        return [(key, _unwrap(fn(job)))]

    def close(self, *, cancel: bool = False, interrupt: bool = False) -> None:
        self._queue.clear()


# numeric libraries' thread pools, one thread per worker (a pool of N workers fills N cores; as Ray
# does for its tasks); a value the user set is kept
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


PR_SET_PDEATHSIG = 1  # prctl(2): the signal a process gets when its parent dies


def _start_worker(parent: int) -> None:
    """A new worker process, before any job is unpickled: single-threaded numeric libraries, Ctrl-C ignored
    while idle, and on Linux a SIGTERM when the process that started it dies (a worker blocked reading its
    pipe never sees a parent killed with kill -9 go, and held its memory for good)."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM))
    except (OSError, AttributeError):  # not Linux: the worker ends when it next reads its closed pipe
        return
    if os.getppid() != parent:  # ``parent`` (the pool's process) died before the request was made
        os._exit(1)


def _call(fn: Callable[[Any], Any], job: Any) -> Any:
    """Run one job in a worker; Ctrl-C interrupts the job (not the idle worker)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return fn(job)
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _processes(worker: ProcessPoolExecutor | None) -> list[Any]:
    """The processes of a one-process pool (the standard library keeps them in a private mapping)."""
    return list((getattr(worker, "_processes", None) or {}).values())


class ProcessPool:
    """``workers`` spawned worker processes, one job each at a time (see the module docstring)."""

    def __init__(self, workers: int, *, context: str = "spawn") -> None:
        if workers < 1:
            raise ConfigError(f"--workers {workers}: expected 1 or more")
        self.slots = workers
        self.name = f"{workers} worker processes"
        self._context = multiprocessing.get_context(context)
        self._workers: list[ProcessPoolExecutor | None] = [None] * workers
        self._running: dict[Future[Any], tuple[int, int]] = {}  # future -> (worker, key)

    def submit(self, key: int, fn: Callable[[Any], Any], job: Any) -> None:
        busy = {w for w, _ in self._running.values()}
        slot = next(w for w in range(self.slots) if w not in busy)
        worker = self._workers[slot]
        if worker is None:
            worker = ProcessPoolExecutor(
                1, mp_context=self._context, initializer=_start_worker, initargs=(os.getpid(),)
            )
            self._workers[slot] = worker
        self._running[worker.submit(_call, fn, job)] = (slot, key)

    def wait(self) -> list[tuple[int, Any]]:
        done, _ = wait_futures(self._running, return_when=FIRST_COMPLETED)
        out: list[tuple[int, Any]] = []
        for future in done:
            slot, key = self._running.pop(future)
            try:
                result = future.result()
                if isinstance(result, Spent):
                    self._retire(slot)
                out.append((key, _unwrap(result)))
            except BrokenProcessPool:
                worker = self._workers[slot]
                if worker is not None:
                    worker.shutdown(wait=False)
                self._workers[slot] = None
                out.append((key, Lost("its worker process died (killed, out of memory or crashed)")))
        return out

    def _retire(self, slot: int) -> None:
        """End the worker process of ``slot`` (its job is done); the next job there starts a new one."""
        worker = self._workers[slot]
        self._workers[slot] = None
        if worker is not None:
            for process in _processes(worker):
                process.terminate()
            worker.shutdown(wait=True)

    def close(self, *, cancel: bool = False, interrupt: bool = False) -> None:
        """Shut the workers down, after their jobs (``cancel``: the jobs not started are dropped). ``interrupt``:
        a running job is interrupted as by Ctrl-C (a SIGINT to its worker; Ctrl-C at a terminal reaches them
        itself), so that it cleans up and ends."""
        if interrupt:
            for slot in {w for w, _ in self._running.values()}:
                worker = self._workers[slot]
                for process in _processes(worker):
                    try:
                        os.kill(process.pid, signal.SIGINT)
                    except ProcessLookupError:
                        pass
        for worker in self._workers:
            if worker is not None:
                worker.shutdown(wait=True, cancel_futures=cancel)
        self._workers = [None] * self.slots
        self._running.clear()


def import_ray() -> Any:
    """The ``ray`` module, or a ``ConfigError`` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise ConfigError(RAY_MISSING) from None
    return ray


def start_local_ray(num_cpus: int | None = None, **options: Any) -> Any:
    """Start a one-machine Ray instance listening on 127.0.0.1 only, without a dashboard; returns ``ray``.

    Ray binds its servers (GCS, raylet, workers, agents) to the node's network address unless it runs
    as a single-machine instance, which its ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` setting selects.
    Ray reads that setting once, when ``ray`` is first imported: it is set in the environment here
    (Ray's own processes inherit it) and, for a ``ray`` imported before this call, on the constant Ray
    read it into, which Ray consults when it starts its servers.
    """
    os.environ[RAY_LOCAL_ONLY] = "0"
    ray = import_ray()
    from ray._private import ray_constants

    ray_constants.ENABLE_RAY_CLUSTER = False
    ray.init(
        num_cpus=num_cpus,
        include_dashboard=False,
        log_to_driver=False,
        logging_level="ERROR",
        **options,
    )
    return ray


def _ray_task(fn: Callable[[Any], Any], job: Any) -> Any:
    return fn(job)


class RayPool:
    """Each job a Ray task requesting ``cpus`` CPUs and ``memory`` bytes (see the module docstring)."""

    name = "Ray"
    slots = sys.maxsize  # Ray queues the tasks and runs as many as the cluster's resources allow

    def __init__(
        self,
        address: str | None = None,
        *,
        cpus: float = 1.0,
        memory: int | None = None,
        local_cpus: int | None = None,
    ) -> None:
        ray = import_ray()
        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            try:
                if address:
                    ray.init(address=address, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
                else:
                    start_local_ray(local_cpus)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                where = f"the Ray cluster at {address}" if address else "a local Ray instance"
                raise ConfigError(
                    f"--ray {address or ''}: cannot connect to {where}: {exc}. Start one with `ray start --head` "
                    "and pass its address (or `--ray auto` on a cluster node)"
                ) from None
            self._started = True
        options: dict[str, Any] = {"num_cpus": cpus, "max_retries": 0}  # run_jobs retries, as for the pool
        if memory:
            options["memory"] = int(memory)
        self._remote = ray.remote(**options)(_ray_task)
        self._running: dict[Any, int] = {}  # object ref -> key

    def submit(self, key: int, fn: Callable[[Any], Any], job: Any) -> None:
        self._running[self._remote.remote(fn, job)] = key

    def wait(self) -> list[tuple[int, Any]]:
        ray = self._ray
        ready, _ = ray.wait(list(self._running), num_returns=1)
        out: list[tuple[int, Any]] = []
        for ref in ready:
            key = self._running.pop(ref)
            try:
                out.append((key, _unwrap(ray.get(ref))))
            except ray.exceptions.RayTaskError as exc:
                if isinstance(exc.cause, KeyboardInterrupt):
                    raise KeyboardInterrupt from None
                out.append((key, Lost(f"the Ray task raised: {exc.cause!r}")))
            except ray.exceptions.RayError as exc:  # worker or node died, out of memory, cancelled
                out.append((key, Lost(f"its Ray worker was lost: {type(exc).__name__}: {str(exc).splitlines()[0]}")))
        return out

    def close(self, *, cancel: bool = False, interrupt: bool = False) -> None:
        if cancel and self._running:
            refs = list(self._running)
            for ref in refs:
                self._ray.cancel(ref)  # the task gets KeyboardInterrupt: its replay removes its temporary files
            self._ray.wait(refs, num_returns=len(refs), timeout=CANCEL_WAIT_S)
        self._running.clear()
        if self._started:
            self._ray.shutdown()
            self._started = False
