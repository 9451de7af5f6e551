"""Reading the kernel's outputs back (the trace port's records, the body-out stream) and comparing them bit for
bit with the golden model.

The comparison runs offline, record by record in retire order (the window kernel's trace is first put back into
the sequential solve's order): the result is the same as the cocotb scoreboard's lock-step check, only later.
The first difference is described for a human (cycle, pass, iteration, slot, manifold, bodies, field, both values).

    cmp = Comparison()
    compare_trace_bits(read_trace(run_dir / "trace.bin", job.fmt, kb.trace_bytes), golden.records, job, cmp)
    compare_body_out(run_dir, job, kb, golden.final, cmp)
    cmp.first_mismatch  # None when bit-exact
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.kernel import stream_format as sf
from models.setup.constraints import BodyTable
from models.golden.contact_solver import CONTACT_PASS, PassRecord, SolverParams, pass_sequence
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import NumberFormat
from models.kernel.record_window import sequential_order
from sim.compile.kernel_build import KernelBuild


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
    wbytes = sf.TRACE_WORDS * fmt.width // 8  # 16 words of W bits = 2W bytes
    if fmt.width in (8, 16, 32, 64):
        words = raw[:, 8:8 + wbytes].copy().view(f"<u{fmt.width // 8}").astype(np.uint64)
    else:
        _, words = sf.unpack_records(raw[:, 8:8 + wbytes], sf.TRACE_WORDS, fmt.width, wbytes * 8)
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


def compare_trace_bits(trace: Trace, golden: list[PassRecord], job: KernelJob, cmp: Comparison) -> None:
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
                cmp.fail(f"{where}: field {sf.TRACE_FIELDS[j]}: kernel {_hex(int(trace.words[k, j]), fmt)} != golden "
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
        cmp.fail(f"body-out: body {b} (dynamic={bool(job.bodies.dynamic[b])}) field {sf.BODY_OUT_FIELDS[j]}: kernel "
                 f"{_hex(int(got[b, j]), fmt)} != golden {_hex(int(want[b, j]), fmt)}")


def writing_passes(job: KernelJob) -> list[int]:
    """The passes (indices of ``pass_sequence``) whose impulses go out on the impulse-out stream: every pass of the
    streaming kernel, the last pass of every fetch of the window kernel."""
    passes = len(pass_sequence(job.params))
    plan = job.record_window
    if plan is None:
        return list(range(passes))
    return [min(f + plan.fetch_passes, passes) - 1 for f in range(0, passes, plan.fetch_passes)]


def expected_impulse_out(job: KernelJob, golden: list[PassRecord]) -> np.ndarray:
    """(writing passes * slots, 4) bit patterns of the impulse-out stream: per writing pass (:func:`writing_passes`),
    per slot (the window kernel's empty lanes included), the golden impulses after the manifold-pass (the trace
    record's first four words), zeros for a slot the kernel rejects and an empty lane."""
    nm = len(job.slots)
    row_of = {pass_sequence(job.params)[p]: r for r, p in enumerate(writing_passes(job))}
    slot_of = np.empty(job.cons.num_manifolds, dtype=np.int64)
    real = job.slots >= 0
    slot_of[job.slots[real]] = np.flatnonzero(real)
    out = np.zeros((len(row_of) * nm, sf.IMPULSE_OUT_WORDS), dtype=np.uint64)
    for rec in golden:
        if (rec.kind, rec.iteration) in row_of:
            rows = row_of[(rec.kind, rec.iteration)] * nm + slot_of[rec.manifold]
            out[rows] = expected_trace_words(job.fmt, rec)[:, :sf.IMPULSE_OUT_WORDS]
    return out


def compare_impulse_out(run_dir: Path, job: KernelJob, golden: list[PassRecord], cmp: Comparison) -> None:
    """The impulse-out stream (impulses in the records): one record per slot and writing pass (the window kernel:
    per window record of its lanes' slots), TLAST on each such pass's last, bit for bit the golden impulses (what
    the DMA wrote back and the next passes or fetches read)."""
    lanes = job.record_window.lanes if job.record_window is not None else 1
    got = sf.unpack_impulse_out(job.fmt, (run_dir / "imp_out.bin").read_bytes(), lanes)
    last = np.frombuffer((run_dir / "imp_out_last.bin").read_bytes(), dtype=np.uint8).astype(bool)
    want = expected_impulse_out(job, golden)
    if got.shape[0] != want.shape[0]:
        cmp.fail(f"{got.shape[0]} impulse-out records, expected {want.shape[0]} (one per slot and writing pass)")
        return
    nm = max(len(job.slots), 1)
    last_slot = np.arange(want.shape[0]) % nm >= nm - lanes
    if not np.array_equal(np.repeat(last, lanes), last_slot):
        cmp.fail(f"impulse-out TLAST on records {np.flatnonzero(last).tolist()[:4]}, expected on each pass's last")
    diff = got ^ want
    cmp.differing_bits += _popcount(diff)
    cmp.differing_words += int(np.count_nonzero(diff))
    bad = np.argwhere(diff != 0)
    if bad.size:
        r, j = (int(x) for x in bad[0])
        block = "fetch" if job.record_window is not None else "pass"  # the window kernel writes once per fetch
        cmp.fail(f"impulse-out record {r} ({block} {r // nm}, slot {r % nm}) word {j}: kernel "
                 f"{_hex(int(got[r, j]), job.fmt)} != golden {_hex(int(want[r, j]), job.fmt)}")


def kernel_bodies(run_dir: Path, job: KernelJob, kb: KernelBuild | None = None) -> BodyTable:
    """``job``'s body table with pos, q, v, w replaced by the kernel's body-out stream in ``run_dir``."""
    bits = (kb or KernelBuild(job.fmt)).body_out_bits
    beats = np.frombuffer((run_dir / "body_out.bin").read_bytes(), np.uint8).reshape(-1, bits // 8)
    return sf.apply_body_out(job.fmt, job.bodies, beats, bits)
