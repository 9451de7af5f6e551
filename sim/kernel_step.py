"""One step of the RTL kernel in the compiled Verilator harness, checked bit for bit against the golden model.

This is the fast path of ``make sim`` (and of ``cocotb_tests/test_pgs_kernel.py``): build the harness of the
job's :class:`~sim.kernel_build.KernelBuild` (once), write the input files and run the harness
(``sim.harness_run``), then compare the trace and the body-out stream with the golden model's
(``sim.trace_compare``) and check the status and issue counters.

    job = KernelJob.from_frame(frame, FP32, SolverParams(4), schedule="hazard", window=181)
    result = run_kernel_step(job, get_preset("zcu102"), Path("build/sim/run"), seed=1)
    result.comparison.first_mismatch  # None when bit-exact
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from models.constraints import BodyTable
from models.contact_solver import PassRecord, SolveResult, solve
from models.dma_model import DmaPreset
from models.integrator import integrate
from models.kernel_job import KernelJob
from models.register_map import ErrorCode, status_flag
from sim.harness_run import ProgressSink, harness_cycle_limit, run_harness, training_run, write_inputs
from sim.kernel_build import KernelBuild, build_kernel
from sim.trace_compare import Comparison, Trace, compare_body_out, compare_impulse_out, compare_trace, read_trace


@dataclass
class Golden:
    records: list[PassRecord]
    solved: SolveResult  # velocities and accumulated impulses after the last pass
    final: BodyTable  # after the solve and the integration
    seconds: float


def golden_step(job: KernelJob) -> Golden:
    """The golden model's trace (every manifold-pass in retire order) and final body table."""
    t0 = time.perf_counter()
    records: list[PassRecord] = []
    solved = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, trace=records.append, initial=job.initial,
                   record_checks=job.record_checks())
    final = integrate(solved.bodies, job.fmt, job.iparams)
    return Golden(records, solved, final, time.perf_counter() - t0)


@dataclass
class KernelResult:
    """What one kernel run measured, and how it compared with the golden model."""

    registers: dict[str, float]  # result.txt: status, cycles, stalls, bubbles, issued, harness_cycles, wall_s, ...
    stream_bytes: dict[str, int]
    comparison: Comparison
    build_seconds: float
    golden_seconds: float
    seed: int
    trace: Trace | None = field(default=None, repr=False)

    @property
    def cycles(self) -> int:
        return int(self.registers["cycles"])

    @property
    def sim_cycles_per_s(self) -> float:
        return self.registers["harness_cycles"] / max(self.registers["wall_s"], 1e-9)

    @property
    def bit_exact(self) -> bool:
        return self.comparison.first_mismatch is None and self.comparison.differing_bits == 0


def check_counters(regs: dict[str, float], job: KernelJob, rejected: int, cmp: Comparison) -> None:
    """The status register and the issue counters against the golden model's step: no error and every
    manifold-pass issued, or, where the golden model rejects ``rejected`` manifold-passes (non-finite impulse
    words read back with the records), exactly those rejected and the non-finite flag (error 5) the first error."""
    want_status = 0 if rejected == 0 else status_flag(ErrorCode.NON_FINITE) | (int(ErrorCode.NON_FINITE) << 8)
    if int(regs["status"]) != want_status:
        cmp.fail(f"kernel status register 0x{int(regs['status']):x}, expected 0x{want_status:x} "
                 f"({rejected} manifold-passes rejected for non-finite impulse words)")
    if int(regs["issued"]) != job.manifold_passes - rejected or int(regs["rejected"]) != rejected:
        cmp.fail(f"kernel issued {int(regs['issued'])} and rejected {int(regs['rejected'])} manifold-passes, "
                 f"expected {job.manifold_passes - rejected} and {rejected}")


def run_kernel_step(job: KernelJob, preset: DmaPreset, run_dir: Path, seed: int, gap_permille: int = 0,
                    backpressure_permille: int = 0, progress: ProgressSink | None = None,
                    golden: Golden | None = None, waves: Path | None = None, wave_cycles: int = 20000,
                    keep_trace: bool = False, body_bits: int = 128, inertia_words: int | None = None,
                    soft_contact: bool = False, compile_profile: str = "quick", datapath: str = "rtl") -> KernelResult:
    """Build (once), run and check one step of the kernel; never raises on a mismatch (see ``comparison``).
    ``inertia_words``: the build's inverse-inertia words per body in place of the job's (1, 3 or 6; a body table
    whose mode needs more is refused when its record is packed). ``soft_contact``: run on the soft contact build
    even where the job is rigid (its options bit clear: the rigid update, e.g. a soft step's relax call).
    ``compile_profile``: how the harness's C++ is compiled (``sim.kernel_build.COMPILE_PROFILES``; a profile-guided
    one trains on this run's first cycles when it builds). ``datapath``: the hand-scheduled pipes ("rtl") or those
    Google XLS compiled ("xls", ``sim.kernel_build.DATAPATHS``)."""
    kb = replace(KernelBuild.for_job(job, preset, waves is not None, body_bits, datapath),
                 compile_profile=compile_profile)
    if inertia_words is not None:
        kb = replace(kb, inertia_words=inertia_words)
    if soft_contact:
        kb = replace(kb, soft_contact=True)
    if job.bodies.num_bodies > kb.max_bodies or job.cons.num_manifolds > kb.max_manifolds:
        raise ValueError(f"{job.bodies.num_bodies} bodies / {job.cons.num_manifolds} manifolds exceed the kernel's "
                         f"MAX_BODIES {kb.max_bodies} / MAX_MANIFOLDS {kb.max_manifolds}")
    stream_bytes = write_inputs(run_dir, job, kb, preset.impulse_turnaround_cycles)
    golden = golden or golden_step(job)
    exe, build_s = build_kernel(kb, training_run(run_dir, job, preset, kb, seed))
    env = None if waves is None else dict(os.environ, PGS_WAVES=str(waves), PGS_WAVE_CYCLES=str(wave_cycles))
    regs = run_harness(exe, run_dir, seed, preset, harness_cycle_limit(job), gap_permille, backpressure_permille,
                       progress, env=env, read_share=job.ddr_read_share(kb.cons_bits))
    cmp = Comparison()
    trace = read_trace(run_dir / "trace.bin", job.fmt, kb.trace_bytes)
    compare_trace(trace, golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    if job.impulses_in_records:
        compare_impulse_out(run_dir, job, golden.records, cmp)
    check_counters(regs, job, golden.solved.rejected_passes, cmp)
    return KernelResult(regs, stream_bytes, cmp, build_s, golden.seconds, seed, trace if keep_trace else None)
