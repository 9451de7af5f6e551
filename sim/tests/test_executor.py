"""sim.parallel.executor: a sweep on two Dask worker processes (each in its own working directory) gives the serial
run's rows, row for row; a failing point and a killed worker (local pool, a LocalCluster without retries, and
dask:local:2 with them) are reported with their commands while the other points finish, with progress lines (done,
running, failed) and the dashboard's address (also a point the local pool takes after a worker died unseen); a rerun
resumes from the results file; a sweep point's command plans that point alone; the costliest points start first; the
kernel store's key is the hash of the kernel build description, its file hashes follow the files."""

from __future__ import annotations

import dataclasses
import io
import logging
import os
import re
import shlex
import signal
import sys
import time
from concurrent import futures
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Iterator

import pytest

from models import scenes
from models.formats.frame import save
from models.formats.number_format import FP16, FP32
from sim.compile import artefacts
from sim.compile import kernel_build
from sim import sweep as sim_sweep
from sim.compile.artefacts import FRAME_DIR, FrameStore, build_key
from sim.parallel.executor import (LOCAL_CLUSTER_CONFIG, LocalPool, Outcome, Task, WorkerDied, Workers, parse_executor,
                                   run_points)
from sim.compile.kernel_build import KernelBuild
from sim.compile.verilator_build import file_digest
from sim.parallel.point_results import PointLog

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, list[Path]]]:
    """A LocalCluster of two worker processes, one thread each, each worker in its own working directory; a
    point that kills its worker fails at once (no retries on other workers)."""
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cl = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                      silence_logs=logging.ERROR)
        client = distributed.Client(cl)
        dirs = []
        for i, worker in enumerate(sorted(client.scheduler_info()["workers"])):
            d = tmp_path_factory.mktemp(f"worker{i}")
            client.run(os.chdir, str(d), workers=[worker])
            dirs.append(d)
        assert sorted(client.run(os.getcwd).values()) == sorted(map(str, dirs))
        try:
            yield cl, dirs
        finally:
            client.close()
            cl.close()


def test_sweep_on_two_dask_workers_matches_serial(tmp_path: Path, cluster: tuple[Any, list[Path]]) -> None:
    cl, worker_dirs = cluster
    frame = save(scenes.load_or_capture("stack", n=2), tmp_path / "stack2.npz")
    args = sim_sweep.parse_args(["--frame", str(frame), "--formats", "fp32,fp16", "--iters", "1,2,4", "--mode",
                                 "model"])
    points, name, frames = sim_sweep.plan(args)
    points.append(dataclasses.replace(points[1], mode="rtl"))  # fp32, 2 iterations on the RTL kernel
    exact = sim_sweep.frame_exact(points[0].frame, tmp_path, 600.0)
    points = [dataclasses.replace(p, exact=exact) for p in points]
    serial = [p.run() for p in points]
    assert [r["mode"] for r in serial] == ["model"] * 6 + ["rtl"] and serial[-1]["differing_bits"] == 0
    assert isinstance(serial[1]["max_dv_vs_exact"], float)  # the stack has an exact reference
    assert serial[-1]["max_dv_vs_exact"] == serial[1]["max_dv_vs_exact"]  # the kernel's numbers: golden's

    log = PointLog(tmp_path / "points.jsonl")
    rows = sim_sweep.run_sweep(points, exact, parse_executor(f"dask:{cl.scheduler_address}"), log, frames, "sweep")
    assert rows == serial
    sim_sweep.write_csv(serial, tmp_path / "serial.csv")
    sim_sweep.write_csv(rows, tmp_path / "dask.csv")
    assert (tmp_path / "dask.csv").read_bytes() == (tmp_path / "serial.csv").read_bytes()
    assert set(log.load()) == {p.key for p in points}
    (digest,) = frames
    shipped = [d for d in worker_dirs if (d / FRAME_DIR / f"{digest}.npz").is_file()]
    assert shipped, "no worker received the frame (each has its own working directory, without the driver's)"
    assert FrameStore(shipped[0] / FRAME_DIR).get(digest).num_bodies == scenes.load_or_capture("stack", n=2).num_bodies


def test_sweep_point_command_reruns_that_point_alone(tmp_path: Path) -> None:
    """A sweep point's command plans exactly that point again, and writes elsewhere than the sweep (whose results
    file a rerun resumes from)."""
    frame = save(scenes.load_or_capture("stack", n=2), tmp_path / "stack2.npz")
    args = sim_sweep.parse_args(["--frame", str(frame), "--formats", "fp32,fp16", "--iters", "2,8", "--mode", "model"])
    points, name, _ = sim_sweep.plan(args)
    for point in points:
        words = shlex.split(point.command)
        assert words[:3] == [".venv/bin/python", "-m", "sim.sweep"]
        alone = sim_sweep.parse_args(words[3:])
        again, again_name, _ = sim_sweep.plan(alone)
        assert [p.key for p in again] == [point.key] and again_name == name
        assert Path(alone.out) != Path(args.out)


@dataclass(frozen=True)
class NamedPoint:
    """A test point keyed by its name, with a command that names it."""

    name: str
    kind: ClassVar[str] = "point"

    @property
    def key(self) -> str:
        return self.name

    @property
    def command(self) -> str:
        return f"{self.kind} {self.name}"


@dataclass(frozen=True)
class FlakyPoint(NamedPoint):
    """A point that raises while ``fail_marker`` exists and kills (SIGKILL) its worker process while ``die_marker``
    exists; each run appends a line to ``<counts>/<name>``."""

    kind: ClassVar[str] = "flaky-point"
    counts: str = ""
    fail_marker: str = ""
    die_marker: str = ""

    def run(self) -> dict[str, Any]:
        with open(Path(self.counts) / self.name, "a") as f:
            f.write("run\n")
        if self.fail_marker and Path(self.fail_marker).exists():
            raise RuntimeError(f"{self.name}: injected failure")
        if self.die_marker and Path(self.die_marker).exists():
            os.kill(os.getpid(), signal.SIGKILL)  # the worker process is killed
        return {"name": self.name, "value": len(self.name) * 1.5}


def _runs(counts: Path) -> dict[str, int]:
    return {p.name: len(p.read_text().splitlines()) for p in counts.iterdir()}


@pytest.mark.parametrize("where", ["local:2", "dask", "dask:local:2"])
def test_failing_point_and_dying_worker(tmp_path: Path, where: str, request: pytest.FixtureRequest) -> None:
    if where.startswith("dask"):
        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import a test module
    if where == "dask":  # no retries: the point that kills its worker fails at once
        where = f"dask:{request.getfixturevalue('cluster')[0].scheduler_address}"
    spec = parse_executor(where)
    counts, fail, die = tmp_path / "counts", tmp_path / "fail", tmp_path / "die"
    counts.mkdir()
    fail.touch()
    die.touch()
    points = [FlakyPoint(f"p{i}", str(counts), str(fail) if i == 1 else "", str(die) if i == 3 else "")
              for i in range(5)]
    log = PointLog(tmp_path / "points.jsonl")
    progress = io.StringIO()
    first = run_points(points, spec, log, label="flaky", stream=progress)
    lines = progress.getvalue().splitlines()
    assert lines[0].startswith(f"flaky: 5 of 5 points to run (0 finished earlier) on {spec.describe()}")
    assert ("; Dask dashboard: http://" in lines[0]) == (spec.kind != "local")
    status = [line for line in lines if line.startswith("[flaky] ")]  # a line per finished or failed point
    counts_seen = [tuple(map(int, m.groups())) for m in
                   (re.match(r"\[flaky\] (\d)/5 done, (\d) running, (\d) failed: ", line) for line in status) if m]
    assert len(counts_seen) == len(status) == 5 and counts_seen[-1] == (3, 0, 2)
    assert all(running <= 2 for _, running, _ in counts_seen) and any(running for _, running, _ in counts_seen)
    assert [d + f for d, _, f in counts_seen] == sorted(d + f for d, _, f in counts_seen)
    assert any("FAILED p1: p1: injected failure" in line for line in lines)
    assert any("reproduce: flaky-point p1" in line for line in lines)  # the describe() lines follow the FAILED one
    by_key = {f.key: f for f in first.failures}
    assert sorted(by_key) == ["p1", "p3"]
    assert by_key["p1"].error == "p1: injected failure" and by_key["p1"].command == "flaky-point p1"
    assert "died" in by_key["p3"].error and by_key["p3"].command == "flaky-point p3"
    assert "reproduce: flaky-point p3" in by_key["p3"].describe()
    assert sorted(first.rows) == ["p0", "p2", "p4"] and sorted(log.load()) == ["p0", "p2", "p4"]
    before = _runs(counts)

    fail.unlink()
    die.unlink()
    second = run_points(points, spec, log, label="flaky")
    assert not second.failures and second.resumed == 3
    assert second.ordered(points) == [{"name": f"p{i}", "value": 3.0} for i in range(5)]
    after = _runs(counts)
    assert {k: after[k] - before[k] for k in after} == {"p0": 0, "p1": 1, "p2": 0, "p3": 1, "p4": 0}


@dataclass(frozen=True)
class TimedPoint(NamedPoint):
    """A point of a given ``cost`` that records when it started in ``<starts>/<name>``."""

    kind: ClassVar[str] = "timed-point"
    cost: float = 0.0
    starts: str = ""

    def run(self) -> dict[str, Any]:
        (Path(self.starts) / self.name).write_text(repr(time.time()))
        time.sleep(0.3)
        return {"name": self.name, "pid": os.getpid()}


@pytest.mark.parametrize("where", ["local:1", "dask:local:2"])
def test_costliest_points_start_first(tmp_path: Path, where: str) -> None:
    """Points start in the order of their cost (a large point left for the end runs alone while the other workers
    idle); a ``Workers`` handle started before the points serves two runs and stays open between them."""
    import dask

    if where.startswith("dask"):
        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    costs = [1.0, 5.0, 2.0, 33.0, 3.0, 17.0]
    points = [TimedPoint(f"p{i}", c, str(tmp_path)) for i, c in enumerate(costs)]
    by_cost = [p.name for p in sorted(points, key=lambda p: -p.cost)]
    second = tmp_path / "second"
    second.mkdir()
    progress = io.StringIO()
    workers = Workers(parse_executor(where))
    try:
        result = run_points(points, workers, label="timed", stream=progress)
        again = run_points([TimedPoint("q", 1.0, str(second))], workers, label="timed", stream=progress)
        if where.startswith("dask"):  # the LocalCluster's workers run with its quiet settings
            seen = workers.backend().client.run(lambda: {k: dask.config.get(k) for k in LOCAL_CLUSTER_CONFIG})
            assert list(seen.values()) == [LOCAL_CLUSTER_CONFIG] * 2
    finally:
        workers.close()
    assert not result.failures and again.ordered([TimedPoint("q", 1.0, "")])[0]["name"] == "q"
    assert [r["name"] for r in result.ordered(points)] == [p.name for p in points]
    started = [p.name for p in sorted(points, key=lambda p: float((tmp_path / p.name).read_text()))]
    if where == "local:1":
        assert started == by_cost
    else:
        assert set(started[:2]) == set(by_cost[:2])  # one on each worker
        assert "Dask dashboard: http://" in progress.getvalue().splitlines()[0]
        assert len({r["pid"] for r in result.rows.values()}) == 2  # two worker processes shared the points


def test_local_pool_takes_points_while_a_dead_worker_goes_unseen(tmp_path: Path) -> None:
    """A point submitted after a worker died, before the driver's next wait sees it, is neither refused with an
    exception nor lost: it died with the pool (not alone), and the replaced pool runs the next point."""
    counts, die = tmp_path / "counts", tmp_path / "die"
    counts.mkdir()
    die.touch()
    pool = LocalPool(2)
    try:
        dying = pool.submit(Task(FlakyPoint("p0", str(counts), die_marker=str(die))))
        futures.wait([dying])  # the pool is broken now (its manager marks it before failing the futures)
        late = pool.submit(Task(FlakyPoint("p1", str(counts))))
        outcomes = dict(pool.wait([dying, late]))
        assert set(outcomes) == {dying, late}
        assert all(isinstance(o, WorkerDied) and not o.alone for o in outcomes.values())
        after = pool.submit(Task(FlakyPoint("p2", str(counts))))
        ((_, outcome),) = pool.wait([after])
        assert isinstance(outcome, Outcome) and outcome.row == {"name": "p2", "value": 3.0} and not outcome.error
    finally:
        pool.close()


def test_kernel_store_key_is_the_build_description(monkeypatch: pytest.MonkeyPatch) -> None:
    """The store's key is a hash of the one kernel build description: equal descriptions share it, every field that
    changes the build changes it, and what is hashed is what every kernel build passes to Verilator."""
    base = KernelBuild(FP32)
    assert build_key(base) == build_key(KernelBuild(FP32))
    variants = [base, KernelBuild(FP16), KernelBuild(FP32, cons_bits=256), KernelBuild(FP32, body_in_bits=512),
                KernelBuild(FP32, window=64), KernelBuild(FP32, compile_profile="o0"), KernelBuild(FP32, waves=True),
                KernelBuild(FP32, friction_sign_bug=True)]
    assert len({build_key(kb) for kb in variants}) == len(variants)
    calls: list[dict[str, Any]] = []
    monkeypatch.setattr(kernel_build, "build", lambda **kw: calls.append(kw) or Path("exe"))
    kernel_build.verilate_kernel(base, build_dir=Path("d"), lock=False)
    assert calls == [{**kernel_build.kernel_build_args(base, Path("d")), "lock": False}]


def test_file_digest_follows_the_file(tmp_path: Path) -> None:
    """The kernel store's file hashes are kept between points, and hashed again once a file changes."""
    path = tmp_path / "source.sv"
    path.write_text("module a; endmodule\n")
    first = file_digest(path)
    assert file_digest(path) == first == artefacts.sha256_bytes(path.read_bytes())
    path.write_text("module b; endmodule\n")
    os.utime(path, ns=(time.time_ns(), time.time_ns() + 1_000_000))
    assert file_digest(path) == artefacts.sha256_bytes(path.read_bytes()) != first


@pytest.mark.parametrize("text", ["local:0", "local:x", "dask:", "dask:local:", "dask:http://h:1", "dask:host",
                                  "ray:4", ""])
def test_bad_executor_spec(text: str) -> None:
    with pytest.raises(ValueError, match="EXECUTOR must be local:N, dask:local:N or dask:tcp://host:port"):
        parse_executor(text)


def test_executor_specs() -> None:
    assert parse_executor("local:3").describe() == "local:3"
    assert parse_executor("dask:local:2").describe() == "dask:local:2"
    assert parse_executor("dask:tcp://10.0.0.1:8786").address == "tcp://10.0.0.1:8786"
    assert parse_executor("dask:sched:8786").address == "tcp://sched:8786"


def test_results_file_skips_a_torn_line(tmp_path: Path) -> None:
    log = PointLog(tmp_path / "p.jsonl")
    log.append("a", {"x": 1})
    with open(log.path, "a") as f:
        f.write('{"key": "b", "row": {"x"')  # an interrupted run
    log.append("c", {"x": 3})
    assert log.load() == {"a": {"x": 1}, "c": {"x": 3}}
