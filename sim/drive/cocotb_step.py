"""One step of the RTL kernel through cocotb (``make sim DRIVER=cocotb``): the host driver, the AXI DMA models
and the batch scoreboard of ``cocotb_tests/`` on the transaction-level bench, checked bit for bit.

The step is written as a co-simulation case (:func:`write_case`: the packed streams of
``models/kernel/stream_format.py``, the golden model's expected trace and body-out stream, the kernel's arguments), the
bench (``sim.drive.cocotb_run.BurstBench``: the kernel with its AXI4-Streams served by burst buffers and its trace
collected in batches) is built once, and the cocotb test ``run_step_bursts`` of ``cocotb_tests/test_kernel_cosim.py``
runs it: DDR loaded, the DMA engines and the kernel programmed over their registers, every pass streamed through the
MM2S models a burst at a time, every retired record compared with the golden model as its batch arrives (the first
difference names the record, its field and the cycle it retired in), the body table read back over S2MM.

The trace the bench saw (``trace.bin``) and the body-out stream (``body_out.bin``) are then compared once more by
``sim.compare.trace_bits``, as for the compiled harness, so the report's bit-exactness section is the same for both
drivers; the result is a ``sim.drive.kernel_step.KernelResult``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from models.kernel import stream_format as sf
from models.golden.contact_solver import CONTACT_PASS, PassRecord, pass_sequence
from models.timing.cycle_model import lower_bound
from models.timing.platforms import DmaPreset
from models.kernel.kernel_job import KernelJob
from sim.drive.cocotb_run import BurstBench, kernel_cocotb_build
from sim.drive.harness_run import register_writes
from sim.compile.kernel_build import KernelBuild
from sim.drive.kernel_step import Golden, KernelResult
from sim.compare.trace_bits import Comparison, compare_body_out, compare_trace_bits, expected_trace_words, read_trace

# by its package path: cocotb's runner hands the simulator this process's sys.path, which has the repository
COCOTB_TEST_MODULE = "cocotb_tests.test_kernel_cosim"
COCOTB_TEST = "run_step_bursts"
CASE_NAME = "cocotb_case.npz"


def expected_records(job: KernelJob, records: list[PassRecord]) -> dict[str, np.ndarray]:
    """The golden trace flattened to one row per retired manifold-pass, in retire order (the case's expected-trace
    arrays): pass kind, iteration, the manifold's slot in the kernel's order, manifold, its bodies, the 16 words."""
    slot_of = np.empty(job.cons.num_manifolds, dtype=np.int64)
    real = job.slots >= 0
    slot_of[job.slots[real]] = np.flatnonzero(real)
    man = np.concatenate([r.manifold for r in records]).astype(np.int64)
    return {"kind": np.concatenate([np.full(len(r.manifold), 0 if r.kind == CONTACT_PASS else 1) for r in records]),
            "iteration": np.concatenate([np.full(len(r.manifold), r.iteration) for r in records]),
            "slot": slot_of[man], "manifold": man, "body_a": job.cons.body_a[man], "body_b": job.cons.body_b[man],
            "words": np.concatenate([expected_trace_words(job.fmt, r) for r in records])}


def write_case(path: Path, job: KernelJob, golden: Golden, preset: DmaPreset, label: str, seed: int,
               schedule: str, extra_meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write the co-simulation case of ``job`` to ``path`` (``.npz``; read by ``cocotb_tests/test_kernel_cosim.py``);
    returns its metadata (``extra_meta`` overrides: the stall probabilities)."""
    fmt = job.fmt
    layout = job.stream_layout(preset.stream_bits)
    cons = sf.pack_constraint_stream(fmt, job.cons, job.schedule, job.params, beat_bits=preset.stream_bits)
    per_pass = np.split(cons.data, np.flatnonzero(cons.last)[:-1] + 1)
    if len(register_writes(job)) != 9:
        raise ValueError("the cocotb host programs the streaming kernel's nine arguments only")
    body_in = sf.pack_body_table(fmt, job.bodies, inertia_words=job.inertia_words).data
    ip = job.iparams
    meta = {"scene": label, "format": fmt.name, "dma": preset.name, "schedule": schedule, "seed": seed, "idle": 0.0,
            "backpressure": 0.0, "num_bodies": job.bodies.num_bodies, "num_manifolds": len(job.slots),
            "inertia_words": job.inertia_words, "friction_words": job.friction_words,
            "iterations": job.params.iterations,
            "passes": len(pass_sequence(job.params)), "dt": ip.dt,
            "gravity": list(ip.gravity), "damping": ip.damping, "options": int(job.params.interleaved),
            "body_out_record_bytes": layout.body_out_bytes, "bytes_per_manifold": layout.bytes_per_manifold(job.params),
            "fp_events": golden.events.as_dict(), "cycle_lower_bound": lower_bound(job, preset, prefetched=True),
            "stream_bytes": {"body_in": int(body_in.size), "constraints": int(cons.data.size),
                             "body_out": job.bodies.num_bodies * layout.body_out_bytes}} | (extra_meta or {})
    np.savez(path, meta=np.array(json.dumps(meta)), **expected_records(job, golden.records), body_in=body_in,
             body_out=sf.pack_body_out(fmt, golden.final).data,
             **{f"pass{p}": d for p, d in enumerate(per_pass)})
    return meta


def run_cocotb_step(job: KernelJob, preset: DmaPreset, run_dir: Path, seed: int, golden: Golden, label: str,
                    schedule: str, datapath: str = "rtl") -> tuple[KernelResult, KernelBuild]:
    """Build the bench (once), run ``job`` through cocotb and compare; never raises on a mismatch (see the
    result's ``comparison``; a failure inside cocotb is its first mismatch). ``datapath``: whose pipes
    (``sim.kernel_build.DATAPATHS``)."""
    if job.record_window is not None:
        raise ValueError("DRIVER=cocotb runs the streaming kernel (no --record-window)")
    bench = BurstBench(kernel_cocotb_build(job.fmt.name, preset.name, inertia_words=job.inertia_words,
                                           friction_words=job.friction_words, datapath=datapath))
    kb = bench.kernel
    if job.bodies.num_bodies > kb.max_bodies or job.manifolds > kb.max_manifolds:
        raise ValueError(f"{job.bodies.num_bodies} bodies / {job.manifolds} manifolds exceed the kernel's "
                         f"MAX_BODIES {kb.max_bodies} / MAX_MANIFOLDS {kb.max_manifolds}")
    run_dir.mkdir(parents=True, exist_ok=True)
    run_dir = run_dir.resolve()  # the simulator runs in the bench's build directory: its files by absolute path
    case = run_dir / CASE_NAME
    t0 = time.perf_counter()
    meta = write_case(case, job, golden, preset, label, seed, schedule)
    print(f"cocotb case: {time.perf_counter() - t0:.1f} s", flush=True)
    build_s = bench.build()
    trace_file, body_out_file = run_dir / "trace.bin", run_dir / "body_out.bin"
    for f in (trace_file, body_out_file, case.with_suffix(".result.json"), case.with_suffix(".failure.txt")):
        f.unlink(missing_ok=True)
    t0 = time.perf_counter()
    bench.test(COCOTB_TEST_MODULE, seed, {"CASE_FILE": str(case), "TRACE_FILE": str(trace_file),
                                          "BODY_OUT_FILE": str(body_out_file)}, testcase=[COCOTB_TEST])
    total_s = time.perf_counter() - t0
    cmp = Comparison()
    failure = case.with_suffix(".failure.txt")
    if failure.exists():
        cmp.fail(f"cocotb: {failure.read_text().strip()}")
    result_file = case.with_suffix(".result.json")
    summary = json.loads(result_file.read_text()) if result_file.exists() else {}
    if not summary and cmp.first_mismatch is None:
        cmp.fail(f"cocotb test {COCOTB_TEST} wrote no result (see the simulator's log above)")
    if trace_file.exists():
        compare_trace_bits(read_trace(trace_file, job.fmt, kb.trace_bytes), golden.records, job, cmp)
    if body_out_file.exists():
        beats = body_out_file.stat().st_size // (kb.body_out_bits // 8)
        last = np.zeros(beats, np.uint8)
        last[-1:] = 1  # the S2MM model ends the packet at TLAST (a missing or early one changes the byte count)
        (run_dir / "body_out_last.bin").write_bytes(last.tobytes())
        compare_body_out(run_dir, job, kb, golden.final, cmp)
    for name, want in (("status", 0), ("issued", job.manifold_passes)):
        if name in summary and int(summary[name]) != want:
            cmp.fail(f"kernel {name} register {summary[name]}, expected {want}")
    regs = {"cycles": summary.get("cycles", 0), "stalls": summary.get("stall_cycles", 0),
            "bubbles": summary.get("bubble_cycles", 0), "issued": summary.get("issued", 0),
            "status": summary.get("status", 0), "harness_cycles": summary.get("sim_cycles", 0),
            "wall_s": summary.get("wall_s", 0.0), "cpu_s": summary.get("cpu_s", 0.0), "cocotb_process_s": total_s}
    stream_bytes = dict(meta["stream_bytes"])
    print(f"cocotb: {summary.get('sim_cycles', 0):,} cycles in {regs['wall_s']:.1f} s "
          f"({summary.get('sim_cycles_per_s', 0.0):,.0f} cycles/s, CPU {regs['cpu_s']:.1f} s); "
          f"simulator process {total_s:.1f} s; bench build {build_s:.1f} s", flush=True)
    return KernelResult(regs, stream_bytes, cmp, build_s, golden.seconds, seed, None), kb
