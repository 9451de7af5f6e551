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

Floating-point events (``rtl/README.md``): the overflow / underflow / invalid counters the harness reads
(result.txt) must equal the golden model's prediction (``tb.fp_events``) and the fp_status flags must be set
exactly for the non-zero ones; every fp32 and bf16 scene leaves them at zero (fp16 flushes tiny velocity terms to
zero: underflows). ``test_pgs_kernel_fp16_overflow`` spins the top cube of the stack at 2000 rad/s in fp16:
its squared angular velocity overflows in the integration (and the step stays bit-exact).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.contact_solver import SolverParams
from models.dma_model import get_preset
from models.number_format import BF16, EVENT_NAMES, FP16, FP32, NumberFormat
from sim.kernel_run import KernelJob, KernelResult, default_window, run_kernel_step
from tb.fp_events import predicted_events

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


def run_case(case: Case, tmp: Path, spin: tuple[int, float] | None = None) -> KernelResult:
    """Run one case; ``spin`` = (body, rad/s) sets that body's angular velocity about y."""
    frame = scenes.load_or_capture(case.scene, **SCENES[case.scene])
    window = default_window(case.fmt, 512)
    job = KernelJob.from_frame(frame, case.fmt, SolverParams(ITERATIONS), case.schedule_kind, window)
    if spin is not None:
        job.bodies.angular_velocity[spin[0]] = case.fmt.round(np.array([0.0, spin[1], 0.0]))
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
    want = predicted_events(job).as_dict()
    got = {name: int(r[f"fp_{name}"]) for name in EVENT_NAMES}
    print(f"  floating-point events: kernel {got}, golden model {want}, fp_status {int(r['fp_status']):#x}")
    assert got == want, "the kernel's floating-point event counters differ from the golden model's prediction"
    assert int(r["fp_status"]) == sum(1 << k for k, name in enumerate(EVENT_NAMES) if got[name])
    assert int(r["rejected"]) == 0
    if case.fmt.name != "fp16":
        assert got == dict.fromkeys(EVENT_NAMES, 0), "a normal fp32 / bf16 scene must raise no event"
    return res


# fp32 on every scene and schedule; fp16 (the thesis's fastest design) and bfloat16 on the pile in hazard order
# and the stack in frame order (every manifold a hazard): one more build each
CASES = [Case(s, FP32, k) for s in SCENES for k in ("hazard", "pybullet")] + [
    Case(s, f, k) for f in (FP16, BF16) for s, k in (("pile", "hazard"), ("stack", "pybullet"))]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c.scene}-{c.fmt.name}-{c.schedule_kind}")
def test_pgs_kernel(case: Case, tmp_path: Path) -> None:
    run_case(case, tmp_path)


def test_pgs_kernel_fp16_overflow(tmp_path: Path) -> None:
    """The stack's top cube spinning at 2000 rad/s in fp16: the counters (overflow and underflow non-zero) equal
    the golden model's prediction (checked in run_case), and the step is bit-exact."""
    res = run_case(Case("stack", FP16, "pybullet"), tmp_path, spin=(10, 2000.0))
    assert int(res.registers["fp_overflow"]) > 0 and int(res.registers["fp_underflow"]) > 0

