"""Kernel-level bit-exact test of rtl/pgs_kernel.sv against the golden model.

The kernel is built once per number format with Verilator into a compiled C++ harness
(``cocotb_tests/kernel/pgs_kernel_main.cpp``, ``build/verilator/pgs_kernel_<fmt>/``). Per case (scene,
format, schedule) the test packs the body table and the constraint stream of one step
(``models/stream_format.py``), runs the harness (random stream gaps and output backpressure, seeded:
the seed is printed, ``SEED=<int>`` overrides it), and compares bit for bit:

* every trace record, in retire order, against the golden ``solve(..., trace=...)`` PassRecords (pass
  kind, iteration, manifold slot, impulses, vA, wA, vB, wB); the first mismatch stops the test with the
  cycle, slot, manifold, pass, iteration, bodies, field and both values (hex and decimal);
* the body-out stream against ``integrate(solve(...).bodies)`` (every body, pos, q, v, w).

It prints cycles, cycles per manifold-pass, stall and bubble cycles, the build time and the simulated
cycles per second. Schedules: ``hazard`` (window = contact pipe depth, few stalls) and ``pybullet``
(frame order: many hazards; the CAM's stalls must keep it exact).
"""

from __future__ import annotations

import os
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models import stream_format as sf
from models.constraints import body_table, setup_constraints
from models.contact_solver import CONTACT_PASS, PassRecord, SolverParams, solve
from models.integrator import IntegrationParams, integrate
from models.number_format import FP16, FP32, NumberFormat
from models.schedule import make_schedule
from sim.lint import rtl_files
from sim.verilator_build import QUICK_COMPILE_ARGS, REPO_ROOT, build

HERE = Path(__file__).resolve().parent
HARNESS = HERE / "kernel" / "pgs_kernel_main.cpp"
CONTACT_LATENCY = 179  # pgs_contact_pipe LATENCY (fp32); the hazard schedule's window
BODY_IN_W, CONS_W, BODY_OUT_W = 128, 512, 128
GAP_PERMILLE, BP_PERMILLE = 100, 200
ITERATIONS = 4

SCENES = {
    "pile": dict(nx=4, ny=3, nz=4, seed=2),
    "stack": dict(),
    "incline": dict(),
}

_builds: dict[str, tuple[Path, float]] = {}


def build_kernel(fmt: NumberFormat) -> tuple[Path, float]:
    """The harness executable for ``fmt`` (built once per session) and the build time in seconds."""
    if fmt.name not in _builds:
        packages, modules = rtl_files()
        trace_bytes = (16 * fmt.width + 64 + 7) // 8
        t0 = time.monotonic()
        exe = build(packages + modules, "pgs_kernel",
                    parameters={"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits, "MAX_BODIES": 4096,
                                "MAX_MANIFOLDS": 16384, "BODY_IN_W": BODY_IN_W, "CONS_W": CONS_W,
                                "BODY_OUT_W": BODY_OUT_W},
                    cpp_files=[HARNESS], name=f"pgs_kernel_{fmt.name}",
                    cflags=[f"-DBODY_IN_BYTES={BODY_IN_W // 8}", f"-DCONS_BYTES={CONS_W // 8}",
                            f"-DBODY_OUT_BYTES={BODY_OUT_W // 8}", f"-DTRACE_BYTES={trace_bytes}"],
                    extra_args=["-Wno-fatal", *QUICK_COMPILE_ARGS])
        _builds[fmt.name] = (exe, time.monotonic() - t0)
    return _builds[fmt.name]


@dataclass
class Case:
    scene: str
    fmt: NumberFormat
    schedule_kind: str


def _seed() -> int:
    return int(os.environ.get("SEED", "12345"))


def _hex(v: int, fmt: NumberFormat) -> str:
    return f"0x{v:0{(fmt.width + 3) // 4}x} ({fmt.decode(np.uint64(v))!r})"


TRACE_FIELDS = ("impulses", "lin_a", "ang_a", "lin_b", "ang_b")


def run_case(case: Case, tmp: Path) -> dict[str, float]:
    fmt = case.fmt
    frame = scenes.load_or_capture(case.scene, **SCENES[case.scene])
    bodies0 = body_table(frame)
    cons = setup_constraints(frame, bodies0).rounded(fmt)
    bodies = bodies0.rounded(fmt)
    window = CONTACT_LATENCY + 2
    schedule = make_schedule(case.schedule_kind, cons, bodies.dynamic, window=window)
    params = SolverParams(iterations=ITERATIONS)
    iparams = IntegrationParams(dt=frame.dt)
    records: list[PassRecord] = []
    golden = solve(bodies, cons, schedule, fmt, params, trace=records.append)
    final = integrate(golden.bodies, fmt, iparams)

    # streams and registers
    body_stream = sf.pack_body_table(fmt, bodies, BODY_IN_W)
    cons_stream = sf.pack_constraint_stream(fmt, cons, schedule, params, CONS_W)
    slots = sf.schedule_manifolds(schedule)
    enc = lambda x: int(fmt.encode(np.float64(x)))  # noqa: E731
    regs = [(0x10, bodies.num_bodies), (0x18, len(slots)), (0x20, ITERATIONS), (0x28, enc(iparams.dt)),
            (0x30, enc(iparams.gravity[0])), (0x38, enc(iparams.gravity[1])), (0x40, enc(iparams.gravity[2])),
            (0x48, enc(iparams.damping)), (0x50, int(params.interleaved))]
    tmp.mkdir(parents=True, exist_ok=True)
    (tmp / "regs.bin").write_bytes(np.asarray(regs, dtype="<u4").tobytes())
    (tmp / "body_in.bin").write_bytes(body_stream.to_bytes())
    (tmp / "body_in_last.bin").write_bytes(body_stream.last.astype(np.uint8).tobytes())
    (tmp / "cons.bin").write_bytes(cons_stream.to_bytes())
    (tmp / "cons_last.bin").write_bytes(cons_stream.last.astype(np.uint8).tobytes())

    exe, build_s = build_kernel(fmt)
    seed = _seed()
    passes = 2 * ITERATIONS
    max_cycles = 400 * (len(slots) * passes + bodies.num_bodies) + 20000
    print(f"\n[{case.scene}/{fmt.name}/{case.schedule_kind}] seed {seed} (SEED= overrides); "
          f"{bodies.num_bodies} bodies, {len(slots)} manifolds, {len(schedule) - len(slots)} bubbles in the "
          f"schedule (W={window}); build {build_s:.1f} s")
    t0 = time.monotonic()
    proc = subprocess.run([str(exe), str(tmp), str(seed), str(GAP_PERMILLE), str(BP_PERMILLE), str(max_cycles)],
                          capture_output=True, text=True)
    wall = time.monotonic() - t0
    assert proc.returncode == 0, f"harness failed ({proc.returncode}): {proc.stdout}{proc.stderr}"
    res = {k: float(v) for k, v in (line.split() for line in (tmp / "result.txt").read_text().splitlines())}

    # --- trace, record by record in retire order ---
    w = fmt.width
    tbytes = (16 * w + 64 + 7) // 8
    raw = np.frombuffer((tmp / "trace.bin").read_bytes(), dtype=np.uint8).reshape(-1, 8 + tbytes)
    cycles = raw[:, :8].copy().view("<u8")[:, 0]
    _, words = sf.unpack_records(raw[:, 8:], 16, w, tbytes * 8)
    bits = np.unpackbits(raw[:, 8:], axis=1, bitorder="little").astype(np.uint64)
    tail = (bits[:, 16 * w:16 * w + 64] * (np.uint64(1) << np.arange(64, dtype=np.uint64))).sum(axis=1, dtype=np.uint64)
    t_slot = (tail & np.uint64(0xFFFFFFFF)).astype(np.int64)
    t_iter = ((tail >> np.uint64(32)) & np.uint64(0xFFFF)).astype(np.int64)
    t_kind = ((tail >> np.uint64(48)) & np.uint64(1)).astype(np.int64)
    expected = sum(len(r.manifold) for r in records)
    assert len(raw) == expected, f"{len(raw)} trace records, expected {expected}"
    slot_of = {int(m): k for k, m in enumerate(slots)}
    pos = 0
    for rec in records:
        n = len(rec.manifold)
        seg = slice(pos, pos + n)
        exp_slots = np.array([slot_of[int(m)] for m in rec.manifold])
        nimp = 4 if rec.kind == CONTACT_PASS else 2
        exp_words = np.concatenate([
            fmt.encode(rec.impulses), np.zeros((n, 4 - nimp), np.uint64), fmt.encode(rec.lin_a),
            fmt.encode(rec.ang_a), fmt.encode(rec.lin_b), fmt.encode(rec.ang_b)], axis=1)
        got_hdr = np.stack([t_kind[seg], t_iter[seg], t_slot[seg]], axis=1)
        exp_hdr = np.stack([np.full(n, rec.kind), np.full(n, rec.iteration), exp_slots], axis=1)
        bad = np.flatnonzero(np.any(got_hdr != exp_hdr, axis=1) | np.any(words[seg] != exp_words, axis=1))
        if bad.size:
            i = int(bad[0])
            k = pos + i
            m = int(rec.manifold[i])
            names = ["impulse[0]", "impulse[1]", "impulse[2]", "impulse[3]"] + [
                f"{f}.{c}" for f in ("vA", "wA", "vB", "wB") for c in "xyz"]
            where = (f"trace record {k} (cycle {int(cycles[k])}): pass kind {rec.kind} iteration {rec.iteration}, "
                     f"slot {exp_slots[i]}, manifold {m}, bodies A={int(cons.body_a[m])} B={int(cons.body_b[m])}")
            if np.any(got_hdr[i] != exp_hdr[i]):
                pytest.fail(f"{where}: header (kind, iteration, slot) {got_hdr[i].tolist()} != {exp_hdr[i].tolist()}")
            j = int(np.flatnonzero(words[k] != exp_words[i])[0])
            pytest.fail(f"{where}: field {names[j]}: kernel {_hex(int(words[k, j]), fmt)} != golden "
                        f"{_hex(int(exp_words[i, j]), fmt)}")
        pos += n

    # --- final body table ---
    out_beats = np.frombuffer((tmp / "body_out.bin").read_bytes(), dtype=np.uint8).reshape(-1, BODY_OUT_W // 8)
    out_last = np.frombuffer((tmp / "body_out_last.bin").read_bytes(), dtype=np.uint8)
    exp_out = sf.pack_body_out(fmt, final, BODY_OUT_W)
    assert out_beats.shape[0] == exp_out.num_beats, f"{out_beats.shape[0]} body-out beats, expected {exp_out.num_beats}"
    assert np.array_equal(out_last.astype(bool), exp_out.last), "body-out TLAST misplaced"
    got = sf.unpack_body_out(fmt, out_beats, BODY_OUT_W)
    exp = sf.body_out_words(fmt, final)
    bad = np.argwhere(got != exp)
    if bad.size:
        b, j = (int(x) for x in bad[0])
        names = [f"{f}.{c}" for f, cs in (("pos", "xyz"), ("q", "xyzw"), ("v", "xyz"), ("w", "xyz")) for c in cs]
        pytest.fail(f"body-out: body {b} (dynamic={bool(bodies.dynamic[b])}) field {names[j]}: kernel "
                    f"{_hex(int(got[b, j]), fmt)} != golden {_hex(int(exp[b, j]), fmt)}")

    assert int(res["status"]) == 0, f"kernel status register 0x{int(res['status']):x}"
    issued = int(res["issued"])
    assert issued == len(slots) * passes
    stats = {"cycles": res["cycles"], "stalls": res["stalls"], "bubbles": res["bubbles"], "issued": issued,
             "build_s": build_s, "sim_cps": res["harness_cycles"] / max(res["wall_s"], 1e-9), "wall_s": wall}
    print(f"  cycles {int(res['cycles'])}, {res['cycles'] / issued:.2f} cycles per manifold-pass, stalls "
          f"{int(res['stalls'])}, bubbles {int(res['bubbles'])}, issued {issued}; simulated "
          f"{stats['sim_cps'] / 1e3:.1f} kcycles/s ({res['wall_s']:.2f} s); bit-exact: {len(raw)} trace records, "
          f"{bodies.num_bodies} bodies")
    return stats


CASES = [Case(s, FP32, k) for s in SCENES for k in ("hazard", "pybullet")]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c.scene}-{c.fmt.name}-{c.schedule_kind}")
def test_pgs_kernel(case: Case, tmp_path: Path) -> None:
    run_case(case, tmp_path)
