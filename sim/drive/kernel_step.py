"""One step of the RTL kernel in the compiled Verilator harness, checked bit for bit against the golden model.

This is the fast path of ``make sim`` (and of ``cocotb_tests/test_pgs_kernel.py``): build the harness of the
job's :class:`~sim.compile.kernel_build.KernelBuild` (once), write the input files and run the harness
(``sim.drive.harness_run``), then compare the trace and the body-out stream with the golden model's
(``sim.compare.trace_bits``) and check the status and issue counters.

    job = KernelJob.from_frame(frame, FP32, SolverParams(4), schedule="hazard", window=181)
    result = run_kernel_step(job, get_preset("zcu102"), Path("build/sim/run"), seed=1)
    result.comparison.first_mismatch  # None when bit-exact
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from models.setup.constraints import BodyTable
from models.formats.number_format import EVENT_NAMES, FpEvents
from models.golden.contact_solver import FRICTION_PASS, PassRecord, SolveResult, solve
from models.timing.platforms import DmaPreset
from models.golden.integrator import integrate
from models.kernel.kernel_job import KernelJob
from models.kernel.register_map import ErrorCode, status_flag
from models.setup.tangent_basis import plane_space_in
from sim.drive.cocotb_run import waves_enabled
from sim.drive.harness_run import ProgressSink, harness_cycle_limit, run_harness, training_run, write_inputs
from sim.compile.kernel_build import KernelBuild, build_kernel
from sim.compare.trace_bits import (Comparison, Trace, compare_body_out, compare_impulse_out, compare_trace_bits,
                                    read_trace)


@dataclass
class Golden:
    records: list[PassRecord]
    solved: SolveResult  # velocities and accumulated impulses after the last pass
    final: BodyTable  # after the solve and the integration
    seconds: float
    # the floating-point events of every operation the kernel computes in the step, counted by the golden model's own
    # arithmetic (``NumberFormat.counting``): what the kernel's three event counters must hold
    events: FpEvents = field(default_factory=FpEvents)


def golden_step(job: KernelJob) -> Golden:
    """The golden model's trace (every manifold-pass in retire order), final body table and floating-point events.

    The events are the golden model's count of its own operations: every point of every contact manifold-pass, the
    spin damping of every friction manifold-pass and the run constants of every body's integration, which the
    golden model computes as the kernel's pipes do (``models/golden/OPERATION_ORDER.md``, "Events"). One operation
    of the kernel is not in the golden model's step and is counted here: with the tangents derived on chip
    (``KernelJob.tangents_on_chip``) the kernel's friction pipe derives them in every friction manifold-pass it issues,
    where the golden model's job holds them derived once (``models.setup.tangent_basis.derive_tangents``)."""
    t0 = time.perf_counter()
    ar = job.fmt.counting()
    records: list[PassRecord] = []

    def derive_tangents_per_pass(kind: int, idx: np.ndarray, g: object, imp: object) -> None:
        if kind == FRICTION_PASS:
            plane_space_in(ar, job.cons.normal[idx])  # the values are the job's tangents; the events are counted

    with np.errstate(all="ignore"):
        solved = solve(job.bodies, job.cons, job.schedule, ar, job.params, trace=records.append,
                       initial=job.initial, record_checks=job.record_checks(),
                       inputs=derive_tangents_per_pass if job.tangents_on_chip else None)
        final = integrate(solved.bodies, ar, job.iparams)
    return Golden(records, solved, final, time.perf_counter() - t0, ar.events)


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


def check_counters(regs: dict[str, float], job: KernelJob, rejected: int, cmp: Comparison,
                   events: FpEvents | None = None) -> None:
    """The status register and the issue counters against the golden model's step: no error and every
    manifold-pass issued, or, where the golden model rejects ``rejected`` manifold-passes (non-finite impulse
    words read back with the records), exactly those rejected and the non-finite flag (error 5) the first error;
    the three floating-point event counters equal to the golden model's ``events`` and the sticky ``fp_status``
    flags set for exactly the kinds that occurred."""
    want_status = 0 if rejected == 0 else status_flag(ErrorCode.NON_FINITE) | (int(ErrorCode.NON_FINITE) << 8)
    if int(regs["status"]) != want_status:
        cmp.fail(f"kernel status register 0x{int(regs['status']):x}, expected 0x{want_status:x} "
                 f"({rejected} manifold-passes rejected for non-finite impulse words)")
    if int(regs["issued"]) != job.manifold_passes - rejected or int(regs["rejected"]) != rejected:
        cmp.fail(f"kernel issued {int(regs['issued'])} and rejected {int(regs['rejected'])} manifold-passes, "
                 f"expected {job.manifold_passes - rejected} and {rejected}")
    if events is not None:
        got = {name: int(regs[f"fp_{name}"]) for name in EVENT_NAMES}
        if got != events.as_dict():
            cmp.fail(f"kernel floating-point event counters {got}, the golden model counts {events.as_dict()}")
        flags = sum(1 << k for k, name in enumerate(EVENT_NAMES) if got[name])
        if int(regs["fp_status"]) != flags:
            cmp.fail(f"kernel fp_status 0x{int(regs['fp_status']):x}, expected 0x{flags:x} for the events {got}")


def _build_events(job: KernelJob, kb: KernelBuild, golden: Golden) -> FpEvents:
    """The events the kernel build counts on ``job``: the golden model's, or, on a build with the full 3x3 inverse
    inertia (6 words) running a diagonal job, those of the golden step with the job's diagonal written as the full
    matrix (zeros off the diagonal), whose products the build computes."""
    ii = job.bodies.inv_inertia
    if kb.inertia_words != 6 or ii.shape[1] == 6:
        return golden.events
    full = np.concatenate([ii, np.zeros_like(ii)], axis=1)  # models.setup.inertia.FULL_ORDER: xx, yy, zz first
    return golden_step(replace(job, bodies=replace(job.bodies, inv_inertia=full))).events


def run_kernel_step(job: KernelJob, preset: DmaPreset, run_dir: Path, seed: int, gap_permille: int = 0,
                    backpressure_permille: int = 0, progress: ProgressSink | None = None,
                    golden: Golden | None = None, waves: Path | None = None, wave_cycles: int = 20000,
                    keep_trace: bool = False, body_bits: int = 128, inertia_words: int | None = None,
                    soft_contact: bool = False, compile_profile: str = "quick", datapath: str = "rtl") -> KernelResult:
    """Build (once), run and check one step of the kernel; never raises on a mismatch (see ``comparison``).
    ``inertia_words``: the build's inverse-inertia words per body in place of the job's (1, 3 or 6; a body table
    whose mode needs more is refused when its record is packed). ``soft_contact``: run on the soft contact build
    even where the job is rigid (its options bit clear: the rigid update, e.g. a soft step's relax call).
    ``compile_profile``: how the harness's C++ is compiled (``sim.compile.kernel_build.COMPILE_PROFILES``; a
    profile-guided one trains on this run's first cycles when it builds). ``waves``: the FST to write (the first
    ``wave_cycles`` cycles); None writes ``run_dir/waves.fst`` where ``WAVES=1`` is set (a failed test run again with
    its waveform), else none. ``datapath``: the hand-scheduled pipes ("rtl") or those Google XLS compiled ("xls",
    ``sim.compile.kernel_build.DATAPATHS``)."""
    if waves is None and waves_enabled():
        waves = Path(run_dir) / "waves.fst"
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
    compare_trace_bits(trace, golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    if job.impulses_in_records:
        compare_impulse_out(run_dir, job, golden.records, cmp)
    check_counters(regs, job, golden.solved.rejected_passes, cmp, _build_events(job, kb, golden))
    return KernelResult(regs, stream_bytes, cmp, build_s, golden.seconds, seed, trace if keep_trace else None)
