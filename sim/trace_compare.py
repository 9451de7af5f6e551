"""One step of the RTL kernel in the compiled Verilator harness, checked bit for bit against the golden model.

This is the fast path of ``make sim`` (and of ``cocotb_tests/test_pgs_kernel.py``): the harness
(``cocotb_tests/kernel/pgs_kernel_main.cpp``) streams the packed body table and constraint stream of
``models/stream_format.py`` into ``rtl/pgs_kernel.sv`` through a model of the DMA preset (DDR token bucket shared
by the streams, start-up latency per MM2S transfer, optional random gaps and backpressure), logs every retired
manifold-pass from the kernel's trace port and the body-out stream to files, and reads the kernel's status and
counter registers over AXI4-Lite. The comparison with the golden model is then done offline, record by record in
retire order: the result is the same as the cocotb scoreboard's lock-step check, only later.

    job = KernelJob.from_frame(frame, FP32, SolverParams(4), schedule="hazard", window=181)
    result = run_kernel_step(job, get_preset("zcu102"), Path("build/sim/run"), seed=1)
    result.first_mismatch  # None when bit-exact
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from models import stream_format as sf
from models.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.contact_solver import CONTACT_PASS, PassRecord, SolverParams, SolveResult, pass_sequence, solve
from models.dma_model import DmaPreset
from models.frame import Frame
from models.integrator import IntegrationParams, integrate
from models.record_window import WindowPlan, plan_window, sequential_order
from models.number_format import NumberFormat
from models.schedule import make_schedule
from sim.lint import rtl_files
from sim.verilator_build import QUICK_COMPILE_ARGS, REPO_ROOT, build

HARNESS = REPO_ROOT / "cocotb_tests" / "kernel" / "pgs_kernel_main.cpp"
# kernel registers (rtl/README.md)
ARG_REGS = {"num_bodies": 0x10, "num_manifolds": 0x18, "iterations": 0x20, "dt": 0x28, "gravity_x": 0x30,
            "gravity_y": 0x38, "gravity_z": 0x40, "damping": 0x48, "options": 0x50, "lag": 0x90,
            "fetch_passes": 0x98}
TRACE_FIELDS = [f"impulse[{i}]" for i in range(4)] + [f"{f}.{c}" for f in ("vA", "wA", "vB", "wB") for c in "xyz"]
BODY_OUT_FIELDS = [f"{f}.{c}" for f, cs in (("pos", "xyz"), ("q", "xyzw"), ("v", "xyz"), ("w", "xyz")) for c in cs]
# cycles allowed per manifold-pass and per body before the harness declares a hang
TIMEOUT_PER_ITEM, TIMEOUT_SLACK = 400, 20000


@dataclass(frozen=True)
class KernelBuild:
    """One parameter set of the kernel harness (each gets its own build directory)."""

    fmt: NumberFormat
    cons_bits: int = 512
    body_in_bits: int = 128
    body_out_bits: int = 128
    max_bodies: int = 65536
    max_manifolds: int = 262144
    waves: bool = False
    window: int = 0  # WINDOW: 0 streams every pass; > 0 the window kernel with a ring of that many records
    window_ctx: int = 8
    lanes: int = 1  # LANES: manifolds issued per cycle (> 1: window kernel only)

    @property
    def name(self) -> str:
        return (f"pgs_kernel_e{self.fmt.exp_bits}m{self.fmt.man_bits}_c{self.cons_bits}"
                + (f"_b{self.body_in_bits}x{self.body_out_bits}" if (self.body_in_bits, self.body_out_bits) != (128, 128)
                   else "")
                + (f"_w{self.window}x{self.window_ctx}" if self.window else "")
                + (f"_l{self.lanes}" if self.lanes > 1 else "") + ("_waves" if self.waves else ""))

    @property
    def trace_bytes(self) -> int:
        return 2 * self.fmt.width + 8  # 16 words of W bits, then 64 bits of slot/iteration/kind

    @property
    def parameters(self) -> dict[str, int]:
        return {"EXP_BITS": self.fmt.exp_bits, "MAN_BITS": self.fmt.man_bits, "MAX_BODIES": self.max_bodies,
                "MAX_MANIFOLDS": self.max_manifolds, "BODY_IN_W": self.body_in_bits, "CONS_W": self.cons_bits,
                "BODY_OUT_W": self.body_out_bits} | (
                    {"WINDOW": self.window, "WINDOW_CTX": self.window_ctx} if self.window else {}) | (
                    {"LANES": self.lanes} if self.lanes > 1 else {})


_built: dict[KernelBuild, tuple[Path, float]] = {}


def build_kernel(kb: KernelBuild) -> tuple[Path, float]:
    """The harness executable of ``kb`` (built once per process; Verilator skips unchanged builds) and the
    seconds the build took."""
    if kb not in _built:
        packages, modules = rtl_files()
        t0 = time.monotonic()
        extra = ["-Wno-fatal", *QUICK_COMPILE_ARGS] + (["--trace-fst", "--trace-structs"] if kb.waves else [])
        exe = build(packages + modules, "pgs_kernel", parameters=kb.parameters, cpp_files=[HARNESS], name=kb.name,
                    cflags=[f"-DBODY_IN_BYTES={kb.body_in_bits // 8}", f"-DCONS_BYTES={kb.cons_bits // 8}",
                            f"-DBODY_OUT_BYTES={kb.body_out_bits // 8}", f"-DTRACE_BYTES={kb.trace_bytes}",
                            f"-DLANES={kb.lanes}"],
                    extra_args=extra)
        _built[kb] = (exe, time.monotonic() - t0)
    return _built[kb]


def default_window(fmt: NumberFormat, cons_bits: int) -> int:
    """Issue slots a manifold must wait before its bodies come back: the deeper pipe's latency in records."""
    from rtl.gen.kernel_graphs import GRAPHS

    layout = sf.StreamLayout(fmt, cons_beat_bits=cons_bits)
    contact = GRAPHS["pgs_contact_pipe"]().schedule().latency_for(fmt.man_bits)
    friction = GRAPHS["pgs_friction_pipe"]().schedule().latency_for(fmt.man_bits)
    return max(math.ceil(contact / layout.contact_beats), math.ceil(friction / layout.friction_beats)) + 2


@dataclass
class KernelJob:
    """One step for the kernel: body table and constraints already rounded to ``fmt``, schedule, parameters."""

    fmt: NumberFormat
    bodies: BodyTable
    cons: ConstraintSet
    schedule: np.ndarray
    params: SolverParams
    iparams: IntegrationParams
    record_window: WindowPlan | None = None  # the window kernel's plan; None: the streaming kernel

    @staticmethod
    def from_frame(frame: Frame, fmt: NumberFormat, params: SolverParams, schedule: str = "hazard",
                   window: int = 64) -> "KernelJob":
        """The step of ``frame`` in ``fmt``, its manifolds ordered by ``make_schedule(schedule, ..., window)``."""
        bodies = body_table(frame)
        cons = setup_constraints(frame, bodies)
        order = make_schedule(schedule, cons, bodies.dynamic, window=window)
        return KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), order, params,
                         IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))

    def windowed(self, depth: int, ctx: int = 8, fetch_passes: int | None = None, lanes: int = 1) -> "KernelJob":
        """This step on the window kernel with a ring of ``depth`` records of ``lanes`` slots
        (``models.record_window.plan_window``)."""
        plan = plan_window(self.cons, self.bodies.dynamic, self.schedule, self.params, depth, ctx, fetch_passes,
                           lanes)
        return KernelJob(self.fmt, self.bodies, self.cons, self.schedule, self.params, self.iparams, plan)

    @property
    def slots(self) -> np.ndarray:
        """The kernel's manifold slots in order (-1: an empty lane of the window kernel)."""
        if self.record_window is not None:
            return self.record_window.slots
        return sf.schedule_manifolds(self.schedule)

    @property
    def manifolds(self) -> int:
        """The manifolds the kernel solves (its slots less the window kernel's empty lanes)."""
        return int(np.count_nonzero(self.slots >= 0))

    @property
    def manifold_passes(self) -> int:
        return self.manifolds * len(pass_sequence(self.params))


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
    solved = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, trace=records.append)
    final = integrate(solved.bodies, job.fmt, job.iparams)
    return Golden(records, solved, final, time.perf_counter() - t0)


def register_writes(job: KernelJob) -> list[tuple[int, int]]:
    """The AXI4-Lite writes that program ``job`` (before ap_start)."""
    enc = lambda x: int(job.fmt.encode(np.float64(x)))  # noqa: E731
    ip = job.iparams
    return [(ARG_REGS["num_bodies"], job.bodies.num_bodies), (ARG_REGS["num_manifolds"], len(job.slots)),
            (ARG_REGS["iterations"], job.params.iterations), (ARG_REGS["dt"], enc(ip.dt)),
            (ARG_REGS["gravity_x"], enc(ip.gravity[0])), (ARG_REGS["gravity_y"], enc(ip.gravity[1])),
            (ARG_REGS["gravity_z"], enc(ip.gravity[2])), (ARG_REGS["damping"], enc(ip.damping)),
            (ARG_REGS["options"], int(job.params.interleaved))] + (
        [] if job.record_window is None else [(ARG_REGS["lag"], job.record_window.lag),
                                              (ARG_REGS["fetch_passes"], job.record_window.fetch_passes)])


def write_inputs(run_dir: Path, job: KernelJob, kb: KernelBuild) -> dict[str, int]:
    """Write the harness's input files into ``run_dir``; return the bytes of each stream."""
    run_dir.mkdir(parents=True, exist_ok=True)
    body = sf.pack_body_table(job.fmt, job.bodies, kb.body_in_bits)
    if job.record_window is None:
        cons = sf.pack_constraint_stream(job.fmt, job.cons, job.schedule, job.params, kb.cons_bits)
    else:
        cons = sf.pack_window_stream(job.fmt, job.cons, job.slots, job.params, job.record_window.fetch_passes,
                                     kb.cons_bits)
    (run_dir / "regs.bin").write_bytes(np.asarray(register_writes(job), dtype="<u4").tobytes())
    (run_dir / "body_in.bin").write_bytes(body.to_bytes())
    (run_dir / "body_in_last.bin").write_bytes(body.last.astype(np.uint8).tobytes())
    (run_dir / "cons.bin").write_bytes(cons.to_bytes())
    (run_dir / "cons_last.bin").write_bytes(cons.last.astype(np.uint8).tobytes())
    out_bytes = job.bodies.num_bodies * sf.StreamLayout(job.fmt, kb.cons_bits, kb.body_out_bits).body_out_bytes
    return {"body_in": body.data.size, "constraints": cons.data.size, "body_out": out_bytes}


ProgressSink = Callable[[int, int], None]  # (cycle, trace records so far)


def run_harness(exe: Path, run_dir: Path, seed: int, preset: DmaPreset, max_cycles: int, gap_permille: int = 0,
                backpressure_permille: int = 0, progress: ProgressSink | None = None, progress_every: int = 65536,
                env: dict[str, str] | None = None) -> dict[str, float]:
    """Run the harness on the inputs in ``run_dir``; return the key/value lines of its ``result.txt``."""
    rate = preset.ddr_bytes_per_cycle
    millibytes = 0 if rate == float("inf") else max(1, round(rate * 1000))
    cmd = [str(exe), str(run_dir), str(seed), str(gap_permille), str(backpressure_permille), str(max_cycles),
           str(millibytes), str(preset.startup_cycles), str(progress_every if progress else 0)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    other: list[str] = []
    for line in proc.stdout:
        parts = line.split()
        if progress is not None and len(parts) == 3 and parts[0] == "progress":
            progress(int(parts[1]), int(parts[2]))
        else:
            other.append(line)
    err = proc.stderr.read()
    if proc.wait() != 0:
        raise KernelRunError(f"kernel harness failed (exit {proc.returncode}): {''.join(other)}{err}".strip())
    return {k: float(v) for k, v in (line.split() for line in (run_dir / "result.txt").read_text().splitlines())}


class KernelRunError(RuntimeError):
    """The harness did not finish (timeout, missing files)."""


@dataclass
class Trace:
    cycle: np.ndarray  # (R,) cycle after ap_start at which the record retired
    kind: np.ndarray
    iteration: np.ndarray
    slot: np.ndarray
    words: np.ndarray  # (R, 16) uint64 bit patterns


def read_trace(path: Path, fmt: NumberFormat, trace_bytes: int) -> Trace:
    raw = np.frombuffer(path.read_bytes(), dtype=np.uint8).reshape(-1, 8 + trace_bytes)
    cycles = raw[:, :8].copy().view("<u8")[:, 0]
    wbytes = 2 * fmt.width  # 16 words of W bits = 2W bytes
    if fmt.width in (8, 16, 32, 64):
        words = raw[:, 8:8 + wbytes].copy().view(f"<u{fmt.width // 8}").astype(np.uint64)
    else:
        _, words = sf.unpack_records(raw[:, 8:8 + wbytes], 16, fmt.width, wbytes * 8)
    tail = raw[:, 8 + wbytes:16 + wbytes].copy().view("<u8")[:, 0]
    return Trace(cycle=cycles, slot=(tail & np.uint64(0xFFFFFFFF)).astype(np.int64),
                 iteration=((tail >> np.uint64(32)) & np.uint64(0xFFFF)).astype(np.int64),
                 kind=((tail >> np.uint64(48)) & np.uint64(1)).astype(np.int64), words=words)


@dataclass
class Comparison:
    """The kernel's outputs against the golden model's."""

    records: int = 0  # trace records compared
    bodies: int = 0  # body-out records compared
    differing_bits: int = 0  # over every compared word (trace and body-out)
    differing_words: int = 0
    first_mismatch: str | None = None  # the first difference in retire order, for a human

    def fail(self, message: str) -> None:
        if self.first_mismatch is None:
            self.first_mismatch = message


def _hex(v: int, fmt: NumberFormat) -> str:
    return f"0x{v:0{(fmt.width + 3) // 4}x} ({float(fmt.decode(np.uint64(v)))!r})"


def _popcount(x: np.ndarray) -> int:
    return int(np.bitwise_count(x).sum())


def expected_trace_words(fmt: NumberFormat, rec: PassRecord) -> np.ndarray:
    """The 16 trace words of a golden pass record (friction passes pad impulses 2..3 with zeros)."""
    n = len(rec.manifold)
    nimp = rec.impulses.shape[1]
    return np.concatenate([fmt.encode(rec.impulses), np.zeros((n, 4 - nimp), np.uint64), fmt.encode(rec.lin_a),
                           fmt.encode(rec.ang_a), fmt.encode(rec.lin_b), fmt.encode(rec.ang_b)], axis=1)


def in_sequential_order(trace: Trace, params: SolverParams) -> Trace:
    """The window kernel's trace (passes interleaved at retire) in the sequential solve's order."""
    order = sequential_order(params, trace.kind, trace.iteration, trace.slot)
    return Trace(trace.cycle[order], trace.kind[order], trace.iteration[order], trace.slot[order], trace.words[order])


def compare_trace(trace: Trace, golden: list[PassRecord], job: KernelJob, cmp: Comparison) -> None:
    """Compare every trace record with the golden pass records, in retire order (the window kernel's: in the
    sequential order, :func:`in_sequential_order`)."""
    fmt = job.fmt
    if job.record_window is not None:
        trace = in_sequential_order(trace, job.params)
    expected = sum(len(r.manifold) for r in golden)
    if len(trace.cycle) != expected:
        cmp.fail(f"{len(trace.cycle)} trace records, expected {expected} (one per manifold-pass)")
    slot_of = np.empty(job.cons.num_manifolds, dtype=np.int64)
    real = job.slots >= 0
    slot_of[job.slots[real]] = np.flatnonzero(real)
    pos = 0
    for rec in golden:
        n = min(len(rec.manifold), len(trace.cycle) - pos)
        if n <= 0:
            break
        seg = slice(pos, pos + n)
        exp_slot = slot_of[rec.manifold[:n]]
        exp_words = expected_trace_words(fmt, rec)[:n]
        diff = trace.words[seg] ^ exp_words
        cmp.differing_bits += _popcount(diff)
        cmp.differing_words += int(np.count_nonzero(diff))
        hdr_bad = (trace.kind[seg] != rec.kind) | (trace.iteration[seg] != rec.iteration) | (trace.slot[seg] != exp_slot)
        bad = np.flatnonzero(hdr_bad | np.any(diff != 0, axis=1))
        if bad.size and cmp.first_mismatch is None:
            i = int(bad[0])
            k, m = pos + i, int(rec.manifold[i])
            kind = "contact" if rec.kind == CONTACT_PASS else "friction"
            where = (f"trace record {k} (cycle {int(trace.cycle[k])}): {kind} pass, iteration {rec.iteration}, "
                     f"slot {int(exp_slot[i])}, manifold {m}, bodies A={int(job.cons.body_a[m])} "
                     f"B={int(job.cons.body_b[m])}")
            if hdr_bad[i]:
                got = [int(trace.kind[k]), int(trace.iteration[k]), int(trace.slot[k])]
                cmp.fail(f"{where}: header (kind, iteration, slot) {got} != "
                         f"{[rec.kind, rec.iteration, int(exp_slot[i])]}")
            else:
                j = int(np.flatnonzero(diff[i])[0])
                cmp.fail(f"{where}: field {TRACE_FIELDS[j]}: kernel {_hex(int(trace.words[k, j]), fmt)} != golden "
                         f"{_hex(int(exp_words[i, j]), fmt)}")
        cmp.records += n
        pos += n


def compare_body_out(run_dir: Path, job: KernelJob, kb: KernelBuild, final: BodyTable, cmp: Comparison) -> None:
    """Compare the body-out stream (beats and TLAST) with the golden final body table."""
    fmt = job.fmt
    beats = np.frombuffer((run_dir / "body_out.bin").read_bytes(), dtype=np.uint8).reshape(-1, kb.body_out_bits // 8)
    last = np.frombuffer((run_dir / "body_out_last.bin").read_bytes(), dtype=np.uint8).astype(bool)
    exp = sf.pack_body_out(fmt, final, kb.body_out_bits)
    if beats.shape[0] != exp.num_beats:
        cmp.fail(f"{beats.shape[0]} body-out beats, expected {exp.num_beats}")
        return
    if not np.array_equal(last, exp.last):
        cmp.fail(f"body-out TLAST on beats {np.flatnonzero(last).tolist()[:4]}, expected on beat {exp.num_beats - 1}")
    got = sf.unpack_body_out(fmt, beats, kb.body_out_bits)
    want = sf.body_out_words(fmt, final)
    diff = got ^ want
    cmp.differing_bits += _popcount(diff)
    cmp.differing_words += int(np.count_nonzero(diff))
    cmp.bodies = int(got.shape[0])
    bad = np.argwhere(diff != 0)
    if bad.size:
        b, j = (int(x) for x in bad[0])
        cmp.fail(f"body-out: body {b} (dynamic={bool(job.bodies.dynamic[b])}) field {BODY_OUT_FIELDS[j]}: kernel "
                 f"{_hex(int(got[b, j]), fmt)} != golden {_hex(int(want[b, j]), fmt)}")


def kernel_bodies(run_dir: Path, job: KernelJob, kb: KernelBuild | None = None) -> BodyTable:
    """``job``'s body table with pos, q, v, w replaced by the kernel's body-out stream in ``run_dir``."""
    bits = (kb or KernelBuild(job.fmt)).body_out_bits
    beats = np.frombuffer((run_dir / "body_out.bin").read_bytes(), np.uint8).reshape(-1, bits // 8)
    return sf.apply_body_out(job.fmt, job.bodies, beats, bits)


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


def kernel_build(job: KernelJob, preset: DmaPreset, waves: bool = False, body_bits: int = 128) -> KernelBuild:
    """The build that runs ``job``: the preset's constraint beat, the window plan's ring, contexts and lanes, body
    streams of ``body_bits``."""
    plan = job.record_window
    return KernelBuild(job.fmt, cons_bits=preset.stream_bits, body_in_bits=body_bits, body_out_bits=body_bits,
                       waves=waves, window=0 if plan is None else plan.depth, window_ctx=8 if plan is None else plan.ctx,
                       lanes=1 if plan is None else plan.lanes)


def run_kernel_step(job: KernelJob, preset: DmaPreset, run_dir: Path, seed: int, gap_permille: int = 0,
                    backpressure_permille: int = 0, progress: ProgressSink | None = None,
                    golden: Golden | None = None, waves: Path | None = None, wave_cycles: int = 20000,
                    keep_trace: bool = False, body_bits: int = 128) -> KernelResult:
    """Build (once), run and check one step of the kernel; never raises on a mismatch (see ``comparison``)."""
    kb = kernel_build(job, preset, waves is not None, body_bits)
    if job.bodies.num_bodies > kb.max_bodies or job.cons.num_manifolds > kb.max_manifolds:
        raise ValueError(f"{job.bodies.num_bodies} bodies / {job.cons.num_manifolds} manifolds exceed the kernel's "
                         f"MAX_BODIES {kb.max_bodies} / MAX_MANIFOLDS {kb.max_manifolds}")
    stream_bytes = write_inputs(run_dir, job, kb)
    golden = golden or golden_step(job)
    exe, build_s = build_kernel(kb)
    env = None
    if waves is not None:
        import os

        env = dict(os.environ, PGS_WAVES=str(waves), PGS_WAVE_CYCLES=str(wave_cycles))
    max_cycles = TIMEOUT_PER_ITEM * (job.manifold_passes + job.bodies.num_bodies) + TIMEOUT_SLACK
    regs = run_harness(exe, run_dir, seed, preset, max_cycles, gap_permille, backpressure_permille, progress,
                       env=env)
    cmp = Comparison()
    trace = read_trace(run_dir / "trace.bin", job.fmt, kb.trace_bytes)
    compare_trace(trace, golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    if int(regs["status"]) != 0:
        cmp.fail(f"kernel status register 0x{int(regs['status']):x} (sticky error) after a good frame")
    if int(regs["issued"]) != job.manifold_passes:
        cmp.fail(f"kernel issued {int(regs['issued'])} manifold-passes, expected {job.manifold_passes}")
    return KernelResult(regs, stream_bytes, cmp, build_s, golden.seconds, seed, trace if keep_trace else None)


def text_progress(total: int, label: str = "kernel", stream=sys.stderr) -> ProgressSink:
    """A progress bar over retired manifold-passes (redrawn in place on a terminal, every 10% otherwise)."""
    t0 = [0.0]  # set at the first report (cycle 0), after the build
    tty = stream.isatty()
    shown = [-1]

    def show(cycle: int, records: int) -> None:
        if not t0[0]:
            t0[0] = time.monotonic()
        frac = min(1.0, records / max(total, 1))
        pct = int(frac * 100)
        if not tty and pct // 10 == shown[0] // 10:
            return
        shown[0] = pct
        el = time.monotonic() - t0[0]
        bar = "#" * int(frac * 30)
        eta = f", ~{el / frac - el:.0f} s left" if frac > 0.02 else ""
        line = (f"{label} [{bar:<30}] {pct:3d}% {records:,}/{total:,} manifold-passes, cycle {cycle:,}, "
                f"{cycle / max(el, 1e-9) / 1e3:.1f} kcycles/s{eta}")
        stream.write(("\r" + line) if tty else (line + "\n"))
        stream.flush()

    return show


def rtl_stepper(preset: DmaPreset, work_dir: Path, seed: int = 1) -> Callable[..., Callable[..., BodyTable]]:
    """A closed-loop stepper factory (``models.closed_loop.StepperFactory``) that runs every step on the RTL kernel
    and fails on the first step whose trace or body table differs from the golden model."""

    def factory(fmt: NumberFormat, params: SolverParams, ip: IntegrationParams) -> Callable[..., BodyTable]:
        count = [0]

        def step(bodies: BodyTable, cons: ConstraintSet, order: np.ndarray) -> BodyTable:
            job = KernelJob(fmt, bodies, cons, order, params, ip)
            run_dir = work_dir / f"step{count[0]:05d}"
            res = run_kernel_step(job, preset, run_dir, seed)
            if not res.bit_exact:
                raise KernelRunError(f"closed-loop step {count[0]}: {res.comparison.first_mismatch}")
            count[0] += 1
            return kernel_bodies(run_dir, job)

        return step

    return factory
