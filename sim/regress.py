"""``make regress SEEDS=N``: the kernel co-simulation over N seeds and more scenes, in parallel
(``sim.parallel.executor``).

Every case (scene x format x schedule x DMA model, :data:`CASES`) and seed runs the compiled harness
(``sim.drive.kernel_step``) twice:

* with the seed's random stream gaps and output backpressure (rates drawn from the seed): every trace record
  and the body table bit-exact with the golden model, status 0, and the cycles no fewer than the cycle model's
  lower bound (``models/timing/cycle_model.py``);
* with deterministic streams: every retire cycle, the total and the stall / bubble counters equal to the cycle
  model's (once per frame: the pile's jitter follows the seed, the other scenes are the same for every seed).

Each point is also a pytest test (``cocotb_tests/test_regress.py``, skipped unless ``REGRESS_SEEDS``, a count: seeds
1..N, or ``REGRESS_SEED``, one seed, is set), so one failing point reruns alone. ``make regress`` builds the kernels
and captures the frames first, runs
every (seed, case) point on ``EXECUTOR`` (``sim/parallel/executor.py``: ``local:JOBS`` by default, ``dask:local:N``,
``dask:tcp://host:port``; kernels from the hash-keyed store ``sim.compile.artefacts.KernelStore``), and prints every
failing seed with the command that reproduces it alone::

    make regress SEEDS=8 JOBS=2
    make regress SEEDS=8 EXECUTOR=dask:tcp://scheduler:8786
    REGRESS_SEED=3 .venv/bin/python -m pytest "cocotb_tests/test_regress.py::test_regress[s3-pile-fp32-hazard-zcu102]"
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from models import scenes
from models.formats.frame import Frame
from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from models.golden.contact_solver import SolverParams
from models.kernel.kernel_job import KernelJob
from models.scenes.kernel_scenes import REGRESS_SCENES, SEEDED, regress_params
from models.timing import cycle_model
from models.timing.platforms import get_preset
from sim.compare import retire_cycles
from sim.compile.artefacts import KernelStore, kernel_store_root
from sim.compile.kernel_build import KernelBuild, build_kernel, default_window, use_kernel_store
from sim.compile.verilator_build import REPO_ROOT
from sim.drive.kernel_step import run_kernel_step
from sim.parallel.executor import parse_executor, run_points

ITERATIONS = 4
OUT = REPO_ROOT / "build" / "regress"


@dataclass(frozen=True)
class Case:
    scene: str
    fmt: NumberFormat
    schedule: str
    dma: str

    @property
    def name(self) -> str:
        return f"{self.scene}-{self.fmt.name}-{self.schedule}-{self.dma}"


CASES = ([Case(s, FP32, k, "zcu102") for s in REGRESS_SCENES for k in ("hazard", "pybullet")]
         + [Case(s, f, k, "zcu102") for f in (FP16, BF16) for s in ("pile", "stack", "pyramid", "plank")
            for k in ("hazard", "pybullet")]
         + [Case(s, FP32, "hazard", "ideal") for s in ("pile", "stack", "impact", "plank")])


def ci_slice(seed: int, points: int) -> list[Case]:
    """The ``points`` cases CI runs with its seed (``REGRESS_SLICE``, ``.ci/run``): one fp16 or bf16 case in frame order
    (pybullet: every manifold a hazard), the rest drawn from every case; the seed picks them, so successive commits
    cover the regression."""
    if not 1 <= points <= len(CASES):
        raise ValueError(f"a slice of 1 to {len(CASES)} make regress points, got {points}")
    rng = random.Random(seed)
    narrow = rng.choice([c for c in CASES if c.fmt is not FP32 and c.schedule == "pybullet"])
    return [narrow, *rng.sample([c for c in CASES if c != narrow], points - 1)]


def stall_rates(seed: int) -> tuple[int, int]:
    """(gap, backpressure) per mille of ``seed``'s random run."""
    rng = random.Random(seed)
    return rng.randrange(0, 400), rng.randrange(0, 600)


def frame_of(case: Case, seed: int) -> Frame:
    return scenes.load_or_capture(case.scene, **regress_params(case.scene, seed))


def reproduce(case: Case, seed: int) -> str:
    return (f'REGRESS_SEED={seed} .venv/bin/python -m pytest '
            f'"cocotb_tests/test_regress.py::test_regress[s{seed}-{case.name}]"')


def check(seed: int, case: Case, tmp_path: Path, deterministic: bool) -> str:
    """Run ``case`` with ``seed`` with random streams and (``deterministic``) without; AssertionError naming what
    differs, else the report."""
    preset = get_preset(case.dma)
    job = KernelJob.from_frame(frame_of(case, seed), case.fmt, SolverParams(ITERATIONS), case.schedule,
                               default_window(case.fmt, preset.stream_bits))
    gap, bp = stall_rates(seed)
    where = f"seed {seed}, {case.name} (gap {gap}, backpressure {bp} per mille); reproduce: {reproduce(case, seed)}"
    res = run_kernel_step(job, preset, tmp_path / "random", seed, gap, bp)
    assert res.bit_exact, f"{where}: {res.comparison.first_mismatch}"
    assert int(res.registers["status"]) == 0, f"{where}: status {int(res.registers['status']):#x}"
    pred = cycle_model.predict_job(job, preset)
    assert res.cycles >= pred.cycles, f"{where}: {res.cycles:,} cycles beat the model's lower bound {pred.cycles:,}"
    report = (f"\n{where}\n  random: {res.cycles:,} cycles, model bound {pred.cycles:,} "
              f"({res.cycles / pred.cycles - 1:+.1%})")
    if deterministic:
        det = run_kernel_step(job, preset, tmp_path / "deterministic", seed, keep_trace=True)
        assert det.bit_exact, f"{where}: {det.comparison.first_mismatch}"
        agree = retire_cycles.compare_run(pred, det, job.slots)
        report += f"\n  deterministic: {agree.describe()}"
        assert agree.ok, f"{where}: {agree.first_mismatch}"
    return report


@dataclass(frozen=True)
class RegressPoint:
    """One (seed, case) of the regression as a ``sim.parallel.executor`` point: the report comes back, not the traces."""

    seed: int
    case: Case
    first_seed: int  # the deterministic run of an unseeded scene happens at this seed only

    @property
    def key(self) -> str:
        return f"s{self.seed}-{self.case.name}"

    @property
    def command(self) -> str:
        return reproduce(self.case, self.seed)

    def run(self) -> dict[str, Any]:
        use_kernel_store(KernelStore(kernel_store_root()))
        deterministic = self.case.scene in SEEDED or self.seed == self.first_seed
        with tempfile.TemporaryDirectory(prefix="pgs-regress-") as tmp:
            return {"report": check(self.seed, self.case, Path(tmp), deterministic)}


def prepare(seed_list: list[int]) -> None:
    """Build every kernel (into the kernel store) and capture every frame before the workers start."""
    use_kernel_store(KernelStore(kernel_store_root()))
    for kb in sorted({KernelBuild(c.fmt, cons_bits=get_preset(c.dma).stream_bits) for c in CASES},
                     key=lambda k: k.name):
        t0 = time.monotonic()
        build_kernel(kb)
        print(f"kernel {kb.name}: ready ({time.monotonic() - t0:.0f} s)", flush=True)
    for case in CASES:
        for seed in seed_list if case.scene in SEEDED else seed_list[:1]:
            frame_of(case, seed)


def failures(junit: Path) -> list[tuple[str, str]]:
    """(test id, first line of the failure) of every failed or erroring test in a junit XML report."""
    out = []
    for tc in ET.parse(junit).getroot().iter("testcase"):
        for bad in list(tc.findall("failure")) + list(tc.findall("error")):
            name = tc.get("name", "")
            out.append((name[name.find("[") + 1:-1] if "[" in name else name,
                        (bad.get("message") or "").splitlines()[0] if bad.get("message") else ""))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="make regress", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=4, help="seeds 1..N")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes of the default executor local:<jobs>")
    ap.add_argument("--executor", default="", help="local:N, dask:local:N or dask:tcp://host:port (sim/parallel/executor.py)")
    args = ap.parse_args(argv)
    try:
        spec = parse_executor(args.executor or f"local:{args.jobs}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    seed_list = list(range(1, args.seeds + 1))
    t0 = time.monotonic()
    prepare(seed_list)
    points = [RegressPoint(s, c, seed_list[0]) for s in seed_list for c in CASES]
    print(f"{len(CASES)} cases x {args.seeds} seeds on {spec.describe()}", flush=True)
    result = run_points(points, spec, label="regress", stream=sys.stdout)
    for row in result.ordered(points):
        print(row["report"])
    print(f"\nmake regress: {len(result.rows)} of {len(points)} passed in {time.monotonic() - t0:.0f} s")
    for failure in result.failures:
        print(failure.describe())
    return 1 if result.failures else 0


if __name__ == "__main__":
    sys.exit(main())
