"""Running the compiled Verilator harness (``sim/harness/pgs_kernel_main.cpp``) on one step's input files.

The harness streams the packed body table and constraint stream of ``models/kernel/stream_format.py`` into
``rtl/pgs_kernel.sv`` through a model of the DMA preset (DDR token bucket shared by the streams, start-up latency
per MM2S transfer, optional random gaps and backpressure), after programming the kernel with the register writes
of ``regs.bin`` (offsets from ``models/kernel/register_map.py``). It logs every retired manifold-pass from the trace
port and the body-out stream to files, and writes the kernel's status and counter registers to ``result.txt``.

    sizes = write_inputs(run_dir, job, kb)
    regs = run_harness(exe, run_dir, seed=1, preset=get_preset("zcu102"), max_cycles=harness_cycle_limit(job))
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from models.kernel import stream_format as sf
from models.golden.contact_solver import pass_sequence
from models.timing.platforms import DmaPreset
from models.timing.kernel_shape import harness_ddr_millibytes
from models.kernel.kernel_job import KernelJob
from models.kernel.register_map import OFFSET, OPT_SOFT_CONTACT
from sim.compile.kernel_build import KernelBuild
from models.kernel import record_window

# cycles allowed per manifold-pass and per body before the harness declares a hang
TIMEOUT_PER_ITEM, TIMEOUT_SLACK = 400, 20000


class KernelRunError(RuntimeError):
    """The harness did not finish (timeout, missing files)."""


def clock_period_ps(preset: DmaPreset) -> int:
    """The platform's clock period in whole ps (the time step of the harness's waveforms)."""
    return round(1e12 / preset.clock_hz)


def harness_cycle_limit(job: KernelJob) -> int:
    """The cycles after which the harness gives ``job`` up as hung."""
    return TIMEOUT_PER_ITEM * (job.manifold_passes + job.bodies.num_bodies) + TIMEOUT_SLACK


def register_writes(job: KernelJob) -> list[tuple[int, int]]:
    """The AXI4-Lite writes (offset, value) that program ``job`` (before ap_start)."""
    enc = lambda x: int(job.fmt.encode(np.float64(x)))  # noqa: E731
    ip = job.iparams
    values = {"num_bodies": job.bodies.num_bodies, "num_manifolds": len(job.slots),
              "iterations": job.params.iterations, "dt": enc(ip.dt), "gravity_x": enc(ip.gravity[0]),
              "gravity_y": enc(ip.gravity[1]), "gravity_z": enc(ip.gravity[2]), "damping": enc(ip.damping),
              "options": int(job.params.interleaved)}
    if job.params.soft_keep is not None:  # the soft contact kernel's keep factors (models/golden/soft_contact.py)
        values |= {"options": values["options"] | OPT_SOFT_CONTACT, "keep_dyn": enc(job.params.soft_keep[0]),
                   "keep_static": enc(job.params.soft_keep[1])}
    if job.record_window is not None:
        values |= {"lag": job.record_window.lag, "fetch_passes": job.record_window.fetch_passes}
    return [(OFFSET[name], value) for name, value in values.items()]


def impulse_plan(job: KernelJob, kb: KernelBuild, turnaround: int) -> bytes:
    """The harness's ``impulse_plan.bin``: records per block (a pass of the streaming kernel, a fetch of the window
    kernel), the read-after-write turnaround, the beats of a record (0: by its block's kind; the window kernel's
    records of ``LANES`` lanes all have the same), each block's kind."""
    plan = job.record_window
    if plan is None:
        records, beats, kinds = len(job.slots), 0, [kind for kind, _ in pass_sequence(job.params)]
    else:
        records, beats = len(job.slots) // plan.lanes, plan.lanes * kb.layout.window_beats
        kinds = [int(k) for k in record_window.window_fetch_kinds(job.params, plan.fetch_passes, one_kind=True) if k is not None]
    return np.asarray([records, turnaround, beats], dtype="<u4").tobytes() + bytes(kinds)


def write_inputs(run_dir: Path, job: KernelJob, kb: KernelBuild, turnaround: int = 1) -> dict[str, int]:
    """Write the harness's input files into ``run_dir``; return the bytes of each stream. ``turnaround``: the DMA's
    cycles from an impulse-out record to the first beat of its reader (``DmaPreset.impulse_turnaround_cycles``)."""
    if job.record_bits is not None:
        raise ValueError("mixed storage (KernelJob.record_bits) has no RTL kernel: the cycle and resource models only")
    if job.params.soft_keep is not None and not kb.soft_contact:
        raise ValueError(f"a soft contact job (soft_keep {job.params.soft_keep}) needs the kernel build with the soft "
                         "contact pipe (KernelBuild.soft_contact, SOFT_CONTACT = 1)")
    run_dir.mkdir(parents=True, exist_ok=True)
    body = sf.pack_body_table(job.fmt, job.bodies, kb.body_in_bits, inertia_words=kb.inertia_words)
    if job.impulses_in_records != kb.impulses_in_records:
        raise ValueError("the job's impulses in the records and the kernel build's IMPULSES_IN_RECORDS disagree")
    if job.tangents_on_chip != kb.tangents_on_chip:
        raise ValueError("the job's friction record layout (tangents derived on chip) and the kernel build's "
                         "TANGENTS_ON_CHIP disagree")
    if job.record_window is None:
        cons = sf.pack_constraint_stream(job.fmt, job.cons, job.schedule, job.params, kb.cons_bits,
                                         job.start_impulses if job.impulses_in_records else None,
                                         job.tangents_on_chip)
    else:
        cons = sf.pack_window_stream(job.fmt, job.cons, job.slots, job.params, job.record_window.fetch_passes,
                                     kb.cons_bits, job.start_impulses if job.impulses_in_records else None)
    (run_dir / "regs.bin").write_bytes(np.asarray(register_writes(job), dtype="<u4").tobytes())
    (run_dir / "body_in.bin").write_bytes(body.to_bytes())
    (run_dir / "body_in_last.bin").write_bytes(body.last.astype(np.uint8).tobytes())
    (run_dir / "cons.bin").write_bytes(cons.to_bytes())
    (run_dir / "cons_last.bin").write_bytes(cons.last.astype(np.uint8).tobytes())
    if job.impulses_in_records:
        (run_dir / "impulse_plan.bin").write_bytes(impulse_plan(job, kb, turnaround))
    out_bytes = job.bodies.num_bodies * sf.StreamLayout(job.fmt, kb.cons_bits, kb.body_out_bits).body_out_bytes
    sizes = {"body_in": body.data.size, "constraints": cons.data.size, "body_out": out_bytes}
    if job.impulses_in_records:
        lay = job.stream_layout(kb.cons_bits)
        sizes["impulses_out"] = len(job.slots) * sum(lay.impulse_write_bytes(k) for k in job.block_kinds)
    return sizes


ProgressSink = Callable[[int, int], None]  # (cycle, trace records so far)

# a profile-guided build's training: the first this many cycles of a run (the whole run when shorter). Measured on
# the thesis frame (docs/results/cosim_speed.md): a profile of the pile's whole step (14,011 cycles) gives that
# step's harness almost the speed-up of one trained on its own first 300,000 cycles
TRAINING_CYCLES = 300_000


def training_run(run_dir: Path, job: KernelJob, preset: DmaPreset, kb: KernelBuild, seed: int = 1,
                 cycles: int = TRAINING_CYCLES) -> Callable[[Path], None]:
    """The training run of a profile-guided build (``sim.compile.kernel_build.verilate_kernel``'s ``train``): the
    harness on the inputs :func:`write_inputs` wrote into ``run_dir`` for ``job`` and ``kb``, stopped after
    ``cycles`` cycles. Its outputs land in ``run_dir``; the run that follows writes them again."""
    limit = min(cycles, harness_cycle_limit(job))

    def train(exe: Path) -> None:
        try:
            run_harness(exe, run_dir, seed, preset, limit, read_share=job.ddr_read_share(kb.cons_bits))
        except KernelRunError as exc:  # stopped at the cycle limit: the harness exits with a timeout
            if f"TIMEOUT after {limit} cycles" not in str(exc):
                raise

    return train


def run_harness(exe: Path, run_dir: Path, seed: int, preset: DmaPreset, max_cycles: int, gap_permille: int = 0,
                backpressure_permille: int = 0, progress: ProgressSink | None = None, progress_every: int = 65536,
                env: dict[str, str] | None = None, read_share: float = 1.0) -> dict[str, float]:
    """Run the harness on the inputs in ``run_dir``; return the key/value lines of its ``result.txt``.
    ``read_share``: the share of the DDR bandwidth the constraint reads get (``StreamLayout.ddr_read_share``)."""
    millibytes = harness_ddr_millibytes(preset, read_share)
    cmd = [str(exe), str(run_dir), str(seed), str(gap_permille), str(backpressure_permille), str(max_cycles),
           str(millibytes), str(preset.startup_cycles), str(progress_every if progress else 0),
           str(clock_period_ps(preset))]
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
