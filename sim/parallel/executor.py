"""One executor for independent points (sweep, stability, resources, regression): a local process pool or Dask.

``EXECUTOR`` (``--executor``) names where the points run:

* ``local:N`` (the default): a pool of N worker processes on this machine;
* ``dask:local:N``: a Dask ``LocalCluster`` of N worker processes with one thread each (to try Dask on one machine);
* ``dask:tcp://host:port``: the workers of an existing Dask distributed scheduler (``dask scheduler`` and
  ``dask worker`` by hand, or dask-jobqueue on a batch system: ``docs/cluster.md``).

A point is a small picklable description (:class:`Point`: a ``key`` that names everything its result depends on, the
shell ``command`` that reproduces it alone, ``run()`` returning its row: a JSON-serialisable dict, and optionally
``cost``, a relative estimate of its run time: the costliest points start first, so that no large point is left to
run alone at the end while the other workers idle). Workers return rows and small reports, never trace files. What a
point needs travels by hash (``sim.compile.artefacts``): a worker that lacks a frame answers with its hash and the
driver sends the bytes with the point again.

Faults: a point that raises, or whose worker dies, is reported with its command; the other points finish. With a
results file (``sim.parallel.point_results.PointLog``) every finished point is recorded as it finishes and a rerun skips
it. Progress (done, running, failed) goes to stderr, with the Dask dashboard's address when there is one.

    result = run_points(points, parse_executor("dask:local:2"), log=PointLog(Path("build/sweep/points.jsonl")))
    result.raise_on_failure()  # or inspect result.failures

A caller with work of its own after the points (writing a csv, a plot) holds the workers itself and closes them
without waiting:

    workers = Workers(parse_executor("dask:local:2"))
    try:
        result = run_points(points, workers)
    finally:
        workers.close(wait=False)  # finishes in a thread while the caller goes on; the interpreter waits for it
"""

from __future__ import annotations

import socket
import sys
import time
import traceback
from collections import deque
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, ThreadPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Iterable, Protocol, Sequence, TextIO

from sim.compile.artefacts import FrameStore, MissingArtefact
from sim.parallel.point_results import PointLog, Row

SPEC_HELP = "EXECUTOR must be local:N, dask:local:N or dask:tcp://host:port (N >= 1 workers)"


class Point(Protocol):
    @property
    def key(self) -> str: ...

    @property
    def command(self) -> str: ...

    def run(self) -> Row: ...


def point_cost(point: Point) -> float:
    """The point's relative run-time estimate (its optional ``cost``; 0 without one)."""
    return float(getattr(point, "cost", 0.0))


@dataclass(frozen=True)
class ExecutorSpec:
    kind: str  # "local", "dask-local" or "dask"
    workers: int = 1  # local and dask-local
    address: str = ""  # dask: the scheduler

    def describe(self) -> str:
        return {"local": f"local:{self.workers}", "dask-local": f"dask:local:{self.workers}"}.get(
            self.kind, f"dask:{self.address}")


def parse_executor(text: str) -> ExecutorSpec:
    """``local:N``, ``dask:local:N`` or ``dask:tcp://host:port``; ValueError naming the forms otherwise."""
    spec = text.strip()

    def count(n: str) -> int:
        if not n.isdigit() or int(n) < 1:
            raise ValueError(f"{SPEC_HELP}, got {text!r}")
        return int(n)

    if spec.startswith("local:"):
        return ExecutorSpec("local", count(spec[len("local:"):]))
    if spec.startswith("dask:local:"):
        return ExecutorSpec("dask-local", count(spec[len("dask:local:"):]))
    if spec.startswith("dask:"):
        address = spec[len("dask:"):]
        host, _, port = address.removeprefix("tcp://").removeprefix("tls://").rpartition(":")
        if "://" in address and not address.startswith(("tcp://", "tls://")) or not host or not port.isdigit():
            raise ValueError(f"{SPEC_HELP}, got {text!r}")
        return ExecutorSpec("dask", address=address if "://" in address else f"tcp://{address}")
    raise ValueError(f"{SPEC_HELP}, got {text!r}")


# --- on the worker ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    point: Any  # a Point
    attachments: tuple[bytes, ...] = ()  # frame files the worker lacked (sim.compile.artefacts.FrameStore)


@dataclass(frozen=True)
class Outcome:
    key: str
    row: Row | None
    error: str = ""  # the point raised: the exception's message
    detail: str = ""  # its type and the end of its traceback
    missing: str = ""  # the worker lacks this artefact (a hash)
    seconds: float = 0.0
    host: str = ""


def run_task(task: Task) -> Outcome:
    """Run one point on this worker; never raises (a failure is an Outcome with ``error``)."""
    store = FrameStore()
    for data in task.attachments:
        store.put(data)
    key = task.point.key
    t0 = time.perf_counter()
    host = socket.gethostname()
    try:
        row = task.point.run()
    except MissingArtefact as exc:
        return Outcome(key, None, missing=exc.digest, host=host)
    except Exception as exc:  # reported with the point's command; the other points go on
        tail = "".join(traceback.format_exception(exc)[-3:]).strip()
        return Outcome(key, None, error=str(exc) or type(exc).__name__, detail=tail,
                       seconds=time.perf_counter() - t0, host=host)
    return Outcome(key, row, seconds=time.perf_counter() - t0, host=host)


# --- backends -----------------------------------------------------------------------------------------------------
class WorkerDied(RuntimeError):
    """The worker process running a point died (or, with ``alone=False``, one beside it did)."""

    def __init__(self, message: str, alone: bool):
        super().__init__(message)
        self.alone = alone


class TaskFailed(RuntimeError):
    """The executor could not run a point (its task failed outside the point, e.g. in transit)."""


class LocalPool:
    """A process pool; a pool broken by a dying worker is replaced, and the points it held rerun one by one."""

    def __init__(self, workers: int):
        self.slots = workers
        self.dashboard = ""
        self.pool = ProcessPoolExecutor(max_workers=workers)

    def submit(self, task: Task) -> Future:
        try:
            return self.pool.submit(run_task, task)
        except (BrokenProcessPool, RuntimeError) as exc:
            # a worker died since the last wait and the pool refuses work ("broken", or shut down by its manager
            # thread): the point fails with the pool's other points, and the next wait reruns them one by one
            refused: Future = Future()
            refused.set_exception(BrokenProcessPool(str(exc)))
            return refused

    def wait(self, futures: Iterable[Future]) -> list[tuple[Future, Outcome | WorkerDied | TaskFailed]]:
        futures = list(futures)
        done, _ = wait(futures, return_when=FIRST_COMPLETED)
        if any(isinstance(f.exception(), BrokenProcessPool) for f in done):
            # the pool is broken: its manager thread reads no more results, so a point not done by now cannot
            # finish (its future fails now or, submitted as the pool broke, never completes): all of them died
            # with the pool, without waiting on them
            finished = {f: self._outcome(f) for f in futures if f.done()}
            broken = [f for f in futures if f not in finished or isinstance(finished[f], WorkerDied)]
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = ProcessPoolExecutor(max_workers=self.slots)
            died = WorkerDied("the worker process died (killed or crashed) while running this point",
                              alone=len(broken) == 1)
            return [(f, died) for f in broken] + [(f, o) for f, o in finished.items() if f not in broken]
        return [(f, self._outcome(f)) for f in done]

    @staticmethod
    def _outcome(f: Future) -> Outcome | WorkerDied | TaskFailed:
        exc = f.exception()
        if exc is None:
            return f.result()
        if isinstance(exc, BrokenProcessPool):
            return WorkerDied("the worker process died (killed or crashed) while running this point", alone=False)
        return TaskFailed(f"{type(exc).__name__}: {exc}")

    def running(self, in_flight: int) -> int:
        return min(in_flight, self.slots)

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


# A LocalCluster on the driver's machine shares its cores with the points. Its worker processes are forked from the
# driver, which has imported everything the points need (spawned, each would start a fresh interpreter and import
# it all again: seconds of CPU per worker); the cluster starts before the driver's own threads do anything. Its
# servers' periodic work (event-loop health ticks every 20 ms, system and memory monitors, the workers' statistical
# profiler every 10 ms) is made rare and the profiler is off; the dashboard and the status pages still work. A
# cluster started elsewhere keeps its own settings (docs/cluster.md).
LOCAL_CLUSTER_CONFIG: dict[str, Any] = {
    "distributed.worker.multiprocessing-method": "fork",
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.tick.cycle": "5s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.worker.profile.enabled": False,
}


class DaskPool:
    """The workers of a Dask scheduler (an existing one, or a LocalCluster started and stopped here). As many
    points are in flight as the workers have threads (counted again as workers come and go): the driver hands out
    the costliest point next as one finishes, where Dask's own queue would place every point on a worker when
    submitted, before their run times show. A point that Dask gives up on (``KilledWorker``: its workers died,
    ``distributed.scheduler.allowed-failures`` times) while other points were in flight is rerun alone, like the
    local pool's."""

    def __init__(self, spec: ExecutorSpec):
        import logging

        import dask
        from distributed import Client, LocalCluster

        self.cluster = None
        if spec.kind == "dask-local":
            with dask.config.set(LOCAL_CLUSTER_CONFIG):  # the nannies hand it on to their worker processes
                self.cluster = LocalCluster(n_workers=spec.workers, threads_per_worker=1, processes=True,
                                            dashboard_address=":0", silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        else:
            try:
                self.client = Client(spec.address, timeout=30)
            except OSError as exc:
                raise ValueError(f"no Dask scheduler at {spec.address} ({exc})") from None
        self.dashboard = self.client.dashboard_link or ""
        self._attempt = 0

    @property
    def slots(self) -> int:
        """The workers' threads now (at least 1: with none yet, a point waits in Dask for the first)."""
        return max(sum(self.client.nthreads().values()), 1)

    def submit(self, task: Task) -> Any:
        self._attempt += 1
        return self.client.submit(run_task, task, pure=False, key=f"point-{task.point.key}-{self._attempt}")

    def wait(self, futures: Iterable[Any]) -> list[tuple[Any, Outcome | WorkerDied | TaskFailed]]:
        from distributed import wait as dask_wait
        from distributed.scheduler import KilledWorker

        futures = list(futures)
        done, _ = dask_wait(futures, return_when="FIRST_COMPLETED")
        out: list[tuple[Any, Outcome | WorkerDied | TaskFailed]] = []
        for f in done:
            try:
                out.append((f, f.result()))
            except KilledWorker as exc:  # it may have shared the worker with the point that killed it
                out.append((f, WorkerDied(f"the worker process died while running this point ({exc})",
                                          alone=len(futures) == 1)))
            except Exception as exc:  # noqa: BLE001 (reported with the point's command)
                out.append((f, TaskFailed(f"{type(exc).__name__}: {exc}")))
            f.release()  # the row is here: Dask must not recompute it when the worker holding it dies
        return out

    def running(self, in_flight: int) -> int:
        return min(in_flight, self.slots)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def open_backend(spec: ExecutorSpec) -> LocalPool | DaskPool:
    return LocalPool(spec.workers) if spec.kind == "local" else DaskPool(spec)


class Workers:
    """The started workers of ``spec`` (ValueError when a scheduler cannot be reached), given to :func:`run_points`,
    which leaves them open: several runs share them. :meth:`close` once done: with ``wait=False`` the closing (a
    LocalCluster's takes seconds: each worker process exits) goes on in a thread while the caller writes its
    outputs, and the interpreter waits for it at exit. Also a context manager (closing with waiting)."""

    def __init__(self, spec: ExecutorSpec):
        self.spec = spec
        self._backend = open_backend(spec)
        self._closer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="executor-close")
        self._closing = False

    def backend(self) -> LocalPool | DaskPool:
        return self._backend

    def close(self, wait: bool = True) -> None:
        if not self._closing:
            self._closing = True
            self._closer.submit(self._backend.close)
        self._closer.shutdown(wait=wait)

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# --- the driver ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PointFailure:
    key: str
    command: str  # reproduces the point alone
    error: str  # what went wrong (the exception's message, or the worker's death)
    detail: str = ""  # the exception's type and the end of its traceback

    def describe(self) -> str:
        first = self.error.splitlines()[0] if self.error else "failed"
        detail = "".join(f"\n  | {line}" for line in self.detail.splitlines()[-3:])
        return f"FAILED {self.key}: {first}{detail}\n  reproduce: {self.command}"


@dataclass
class RunResult:
    rows: dict[str, Row] = field(default_factory=dict)  # by point key
    failures: list[PointFailure] = field(default_factory=list)
    resumed: int = 0  # points whose rows came from the results file
    hosts: dict[str, str] = field(default_factory=dict)  # point key -> the host that ran it (not resumed ones)

    def ordered(self, points: Sequence[Point]) -> list[Row]:
        """The finished points' rows in the order of ``points``."""
        return [self.rows[p.key] for p in points if p.key in self.rows]

    def raise_on_failure(self) -> None:
        if self.failures:
            raise PointsFailed(self.failures)


class PointsFailed(RuntimeError):
    def __init__(self, failures: list[PointFailure]):
        super().__init__(f"{len(failures)} point(s) failed:\n" + "\n".join(f.describe() for f in failures))
        self.failures = failures


def run_points(points: Sequence[Point], executor: ExecutorSpec | Workers, log: PointLog | None = None,
               artefacts: dict[str, bytes] | None = None, label: str = "points",
               stream: TextIO = sys.stderr) -> RunResult:
    """Run every point not already in ``log`` on the workers of ``executor`` (a spec: started and closed here;
    :class:`Workers`: the caller's, left open), the costliest first (:func:`point_cost`); ``artefacts``
    (hash -> bytes) are sent to a worker that lacks them. Returns the rows by key and the failures (each with its
    command)."""
    keys = [p.key for p in points]
    if len(set(keys)) != len(keys):
        raise ValueError(f"{label}: two points share a key")
    result = RunResult()
    earlier = log.load() if log is not None else {}
    result.rows = {p.key: earlier[p.key] for p in points if p.key in earlier}
    result.resumed = len(result.rows)
    todo = deque(Task(p) for p in sorted(points, key=point_cost, reverse=True) if p.key not in earlier)
    if not todo:
        _say(stream, f"{label}: all {len(points)} points finished earlier ({log.path if log else ''})")
        return result
    if isinstance(executor, Workers):
        return _run_tasks(todo, executor.backend(), executor.spec, artefacts or {}, result, log, len(points), label,
                          stream)
    with Workers(executor) as workers:
        return _run_tasks(todo, workers.backend(), executor, artefacts or {}, result, log, len(points), label, stream)


def _run_tasks(todo: deque[Task], backend: LocalPool | DaskPool, spec: ExecutorSpec, artefacts: dict[str, bytes],
               result: RunResult, log: PointLog | None, total: int, label: str, stream: TextIO) -> RunResult:
    where = f" from {log.path}" if log is not None and result.resumed else ""
    _say(stream, f"{label}: {len(todo)} of {total} points to run ({result.resumed} finished earlier{where}) "
                 f"on {spec.describe()}" + (f"; Dask dashboard: {backend.dashboard}" if backend.dashboard else ""))
    suspects: deque[Task] = deque()  # in flight when a local worker died: rerun alone to find the one that kills
    in_flight: dict[Any, Task] = {}
    while todo or suspects or in_flight:
        if suspects:
            if not in_flight:
                task = suspects.popleft()
                in_flight[backend.submit(task)] = task
        else:
            slots = backend.slots
            while todo and len(in_flight) < slots:
                task = todo.popleft()
                in_flight[backend.submit(task)] = task
        for fut, outcome in backend.wait(in_flight):
            task = in_flight.pop(fut)
            failure = _settle(task, outcome, artefacts, todo, suspects, result, log)
            status = (f"{len(result.rows)}/{total} done, {backend.running(len(in_flight))} running, "
                      f"{len(result.failures)} failed")
            if failure is not None:
                _say(stream, f"[{label}] {status}: {failure.describe()}")
            elif isinstance(outcome, Outcome) and outcome.row is not None:
                _say(stream, f"[{label}] {status}: {outcome.key} ({outcome.seconds:.1f} s on {outcome.host})")
    return result


def _settle(task: Task, outcome: Outcome | WorkerDied | TaskFailed, artefacts: dict[str, bytes], todo: deque[Task],
            suspects: deque[Task], result: RunResult, log: PointLog | None) -> PointFailure | None:
    """Record one finished task: a row, a failure, a resend with the artefact the worker lacked, or a suspect."""
    point = task.point
    if isinstance(outcome, WorkerDied):
        if outcome.alone:
            failure = PointFailure(point.key, point.command, str(outcome))
            result.failures.append(failure)
            return failure
        suspects.append(task)
        return None
    if isinstance(outcome, TaskFailed):
        failure = PointFailure(point.key, point.command, str(outcome))
        result.failures.append(failure)
        return failure
    if outcome.missing:
        if outcome.missing in artefacts and not task.attachments:
            todo.appendleft(Task(point, (artefacts[outcome.missing],)))
            return None
        failure = PointFailure(point.key, point.command, f"the worker lacks artefact {outcome.missing}, which the "
                                                         "driver cannot send")
        result.failures.append(failure)
        return failure
    if outcome.row is None:
        failure = PointFailure(point.key, point.command, outcome.error, outcome.detail)
        result.failures.append(failure)
        return failure
    result.rows[point.key] = outcome.row
    result.hosts[point.key] = outcome.host
    if log is not None:
        log.append(point.key, outcome.row)
    return None


def _say(stream: TextIO, line: str) -> None:
    stream.write(line + "\n")
    stream.flush()
