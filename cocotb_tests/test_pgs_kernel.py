"""Kernel-level bit-exact test of rtl/pgs_kernel.sv against the golden model (the ``make sim`` fast path).

The kernel is built once per parameter set with Verilator into the compiled C++ harness
(``cocotb_tests/kernel/pgs_kernel_main.cpp``, ``build/verilator/pgs_kernel_e8m23_c512/``, the same build
``make sim`` uses). Per case (scene, format, schedule) ``sim.kernel_run`` packs the body table and the
constraint stream of one step, runs the harness through the zcu102 DMA model with random stream gaps and
output backpressure on top (seeded: the seed is printed, ``SEED=<int>`` overrides it), and compares bit for bit:

* every trace record, in retire order, against the golden ``solve(..., trace=...)`` PassRecords (pass
  kind, iteration, manifold slot, impulses, vA, wA, vB, wB); the first mismatch fails the test with the
  cycle, slot, manifold, pass, iteration, bodies, field and both values (hex and decimal);
* the body-out stream against ``integrate(solve(...).bodies)`` (every body, pos, q, v, w).

It prints cycles, cycles per manifold-pass, stall and bubble cycles, the build time and the simulated
cycles per second. Schedules: ``hazard`` (window = pipeline depth in records, few stalls) and ``pybullet``
(frame order: many hazards; the CAM's stalls must keep it exact).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import pytest

from models import scenes
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.number_format import BF16, FP16, FP32, NumberFormat
from sim.kernel_run import KernelJob, default_window, run_kernel_step

GAP_PERMILLE, BP_PERMILLE = 100, 200
ITERATIONS = 4

SCENES = {
    "pile": dict(nx=4, ny=3, nz=4, seed=2),
    "stack": dict(),
    "incline": dict(),
}


@dataclass
class Case:
    scene: str
    fmt: NumberFormat
    schedule_kind: str


def _seed() -> int:
    return int(os.environ.get("SEED", "12345"))


def run_case(case: Case, tmp: Path) -> None:
    frame = scenes.load_or_capture(case.scene, **SCENES[case.scene])
    window = default_window(case.fmt, 512)
    job = KernelJob.from_frame(frame, case.fmt, SolverParams(ITERATIONS), case.schedule_kind, window)
    seed = _seed()
    print(f"\n[{case.scene}/{case.fmt.name}/{case.schedule_kind}] seed {seed} (SEED= overrides); "
          f"{job.bodies.num_bodies} bodies, {len(job.slots)} manifolds, {len(job.schedule) - len(job.slots)} bubbles "
          f"in the schedule (W={window})")
    res = run_kernel_step(job, get_preset("zcu102"), tmp, seed, GAP_PERMILLE, BP_PERMILLE)
    if res.comparison.first_mismatch is not None:
        pytest.fail(res.comparison.first_mismatch)
    assert res.bit_exact
    r = res.registers
    print(f"  cycles {res.cycles}, {res.cycles / job.manifold_passes:.2f} cycles per manifold-pass, stalls "
          f"{int(r['stalls'])}, bubbles {int(r['bubbles'])}; build {res.build_seconds:.1f} s; simulated "
          f"{res.sim_cycles_per_s / 1e3:.1f} kcycles/s ({r['wall_s']:.2f} s); bit-exact: "
          f"{res.comparison.records} trace records, {res.comparison.bodies} bodies")


# fp32 on every scene and schedule; fp16 (the thesis's fastest design) and bfloat16 on the pile in hazard order
# and the stack in frame order (every manifold a hazard): one more build each
CASES = [Case(s, FP32, k) for s in SCENES for k in ("hazard", "pybullet")] + [
    Case(s, f, k) for f in (FP16, BF16) for s, k in (("pile", "hazard"), ("stack", "pybullet"))]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c.scene}-{c.fmt.name}-{c.schedule_kind}")
def test_pgs_kernel(case: Case, tmp_path: Path) -> None:
    run_case(case, tmp_path)
