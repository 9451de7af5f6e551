"""Co-simulation of one step: pybullet contacts through the AXI DMA model into the RTL kernel, in cocotb.

pytest prepares a case (scene frame, constraints, schedule, the packed streams of ``models/kernel/stream_format.py``
and the golden model's expected trace and body table) into an ``.npz``; the cocotb test ``run_step`` loads
DDR, programs the DMAs and the kernel over AXI4-Lite (``cocotb_tests/tb/host_driver.py``), starts it, and the
scoreboard (``cocotb_tests/tb/scoreboard.py``) compares every retired manifold-pass as it appears; the final body
table read back over S2MM is compared too. Random idle cycles on every MM2S stream and random backpressure on
S2MM are seeded (the seed is printed; ``SEED=<n>`` reproduces a run); results must be bit-identical whatever the
stalls.
The status register must read 0, no manifold-pass may be rejected, and the floating-point event counters must
equal the golden model's own count (``sim.drive.kernel_step.golden_step``; zero for these fp32 scenes).

The kernel's cycles must not beat the cycle model's lower bound (``models/timing/cycle_model.py``, with the first body
and constraint transfers armed before ap_start, as this host arms them).

``test_scoreboard_catches_friction_sign_bug`` checks the checker: the kernel built with the friction-sign bug
(``KernelBuild(friction_sign_bug=True)``, a build of its own) must be stopped by the scoreboard at the first
friction-pass record (the cocotb test ``run_step_expect_mismatch`` catches the scoreboard's AssertionError and
reports it to pytest).

Transaction-level mode (``test_kernel_cosim_bursts``; ``make sim DRIVER=cocotb`` runs it on any scene): the kernel
inside ``cocotb_tests/tb/pgs_kernel_burst_tb.sv``, whose burst buffers feed and drain its AXI4-Streams and collect
its trace in batches; the same host driver and DMA engines move each transfer a burst at a time
(``BurstDmaStreamPort``), and the batch scoreboard (``BatchTraceScoreboard``) checks every record, a chunk at a
time, naming the first differing record, its field and the cycle it retired in
(``test_batch_scoreboard_names_record_field_and_cycle`` injects one). No Python runs per cycle there, so it is
several times faster; the cycle-level handshake (random idles and backpressure) is what the tests above check.

``WAVES=1`` writes ``build/cocotb/<build>_waves/<case>.fst`` and a GTKWave save file beside it,
``<case>.gtkw`` (control, DMA streams and pipeline signals grouped); both paths are printed. ``MAX_CYCLES=<n>`` in
the simulator's environment stops a ``run_step*`` test after n cycles, every record retired until then checked, and
writes the speed instead of the step's summary (a measurement on a prefix of a long step, as the compiled
harness's ``MAX_CYCLES``).

    .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack      # one case
    .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k bursts     # transaction level
    WAVES=1 .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack -s   # + FST waveform
    gtkwave build/cocotb/pgs_kernel_e8m23_c512_waves/stack-fp32-hazard-zcu102.gtkw
"""

from __future__ import annotations

import json
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cocotb
import numpy as np
import pytest

from models.formats.number_format import EVENT_NAMES, parse_format

TIMEOUT_CYCLES = 2_000_000


@dataclass
class _Step:
    """One step set up in the simulator: the case (``.npz``), the host (DMA, DDR, AXI4-Lite) and the scoreboard."""

    case: Any
    meta: dict
    host: Any
    sb: Any
    batches: Any = None  # transaction level: the bench's trace batches (tb.burst_streams.TraceBatches)
    trace_out: Any = None  # transaction level: the open TRACE_FILE, if any

    async def run(self, cut_cycles: int | None = None):
        """Run the step with the scoreboard watching the trace; the first mismatch raises its AssertionError.
        ``cut_cycles``: stop after that many cycles (a speed measurement on a prefix of a long step; every record
        retired until then checked) and return None."""
        from cocotb.triggers import Timer, select

        from cocotb_tests.tb.host_driver import CLOCK_PERIOD_NS

        passes = [self.case[f"pass{p}"].tobytes() for p in range(self.meta["passes"])]
        # a hang fails the test; a large frame (the thesis scene: 2.3 M cycles) gets four times its lower bound
        timeout = max(TIMEOUT_CYCLES, 4 * int(self.meta.get("cycle_lower_bound") or 0))
        run = self.host.run_step(self.case["body_in"].tobytes(), passes, int(self.case["body_out"].size), timeout)
        monitor = self.sb.monitor() if self.batches is None else self.batches.monitor()
        cut = [] if cut_cycles is None else [Timer(cut_cycles * CLOCK_PERIOD_NS, unit="ns")]
        try:
            which, res = await select(monitor, run, *cut)  # the monitor only ever ends by raising
            if which == 2:
                return None
            if self.batches is not None:  # the records of the last, partial batch and chunk
                self.batches.flush()
                self.sb.flush()
        finally:
            if self.trace_out is not None:
                self.trace_out.close()
        return res


async def _start_step(dut, transaction_level: bool = False) -> _Step:
    """Load the case of ``CASE_FILE``, reset the kernel and program its arguments. ``transaction_level``: ``dut``
    is the transaction-level bench (bursts, batched trace, the batch scoreboard); with ``TRACE_FILE`` set, every
    trace record is also written there (the compiled harness's ``trace.bin`` layout)."""
    from cocotb_tests.tb.burst_streams import TraceBatches
    from cocotb_tests.tb.host_driver import KernelHost
    from cocotb_tests.tb.scoreboard import BatchTraceScoreboard, ExpectedTrace, TraceScoreboard

    from models.timing.platforms import get_preset
    from models.kernel.stream_format import trace_record_bytes
    from sim.drive.cocotb_run import BURST_BEATS, TRACE_BATCH

    with np.load(os.environ["CASE_FILE"], allow_pickle=False) as npz:
        case = dict(npz)
    meta = json.loads(str(case["meta"]))
    fmt = parse_format(meta["format"])
    host = KernelHost(dut, get_preset(meta["dma"]), meta["seed"], idle_prob=meta["idle"],
                      backpressure_prob=meta["backpressure"], transaction_level=transaction_level, burst=BURST_BEATS)
    expected = ExpectedTrace(case["kind"], case["iteration"], case["slot"], case["manifold"], case["body_a"],
                             case["body_b"], case["words"])
    if not transaction_level:
        step = _Step(case, meta, host, TraceScoreboard(dut, fmt, expected))
    else:
        trace_file = open(os.environ["TRACE_FILE"], "wb") if os.environ.get("TRACE_FILE") else None  # noqa: SIM115
        sb = BatchTraceScoreboard(fmt, expected, sink=None if trace_file is None else trace_file.write)
        step = _Step(case, meta, host, sb, TraceBatches(dut, trace_record_bytes(fmt) + 8, TRACE_BATCH, sb.take),
                     trace_file)
    await host.reset()
    await host.program(fmt, meta["num_bodies"], meta["num_manifolds"], meta["iterations"], meta["dt"],
                       tuple(meta["gravity"]), meta["damping"], meta["options"])
    return step


@cocotb.test()
async def run_step(dut) -> None:
    st = await _start_step(dut)
    await _run_and_check(dut, st)


@cocotb.test()
async def run_step_bursts(dut) -> None:
    """The step on the transaction-level bench: bursts through the DMA models, the trace checked in batches; the
    same checks as ``run_step``."""
    st = await _start_step(dut, transaction_level=True)
    try:
        await _run_and_check(dut, st)
    except (AssertionError, TimeoutError) as err:  # for make sim's report (sim/drive/cocotb_step.py)
        Path(os.environ["CASE_FILE"]).with_suffix(".failure.txt").write_text(str(err))
        raise


async def _run_and_check(dut, st: _Step) -> None:
    """Run the step, check the kernel's registers, the trace and the body-out stream, write ``<case>.result.json``."""
    case, meta, sb = st.case, st.meta, st.sb
    cut = int(os.environ["MAX_CYCLES"]) if os.environ.get("MAX_CYCLES") else None
    t0, cpu0 = time.perf_counter(), time.process_time()
    cycle0 = sb.cycle if st.batches is None else int(dut.tb_cycle.value)
    res = await st.run(cut)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    if res is None:  # MAX_CYCLES: the speed on a prefix of the step (every record retired until then compared)
        sim_cycles = (sb.cycle if st.batches is None else int(dut.tb_cycle.value)) - cycle0
        summary = {"scene": meta["scene"], "cut_at_cycles": cut, "sim_cycles": sim_cycles, "wall_s": wall,
                   "cpu_s": cpu, "sim_cycles_per_s": sim_cycles / wall, "records_compared": sb.compared,
                   "transaction_level": st.batches is not None}
        dut._log.info("cosim (cut) %s", json.dumps(summary))
        Path(os.environ["CASE_FILE"]).with_suffix(".result.json").write_text(json.dumps(summary, indent=1))
        return
    assert res.status == 0, f"kernel status register {res.status:#x} (sticky error flags) after a good frame"
    assert res.rejected == 0, f"{res.rejected} manifold-passes rejected in a good frame"
    events = dict(zip(EVENT_NAMES, res.fp_events))
    if meta.get("fp_events") is not None:
        assert events == meta["fp_events"], \
            f"floating-point events {events}, the golden model predicts {meta['fp_events']}"
    assert sb.complete, f"trace: {sb.compared} records compared, {sb.exp.words.shape[0]} expected"
    if meta.get("cycle_lower_bound") is not None:
        assert res.cycles >= meta["cycle_lower_bound"], \
            f"{res.cycles:,} kernel cycles beat the cycle model's lower bound of {meta['cycle_lower_bound']:,}"
    want = case["body_out"].tobytes()
    if res.body_out != want:
        got_w = np.frombuffer(res.body_out.ljust(len(want), b"\0"), np.uint8)
        first = int(np.flatnonzero(got_w != case["body_out"])[0])
        raise AssertionError(f"body-out stream differs from the golden model at byte {first} "
                             f"(record {first // meta['body_out_record_bytes']}); got {len(res.body_out)} bytes")
    mp = meta["num_manifolds"] * meta["passes"]
    sim_cycles = (sb.cycle if st.batches is None else int(dut.tb_cycle.value)) - cycle0
    summary = {"scene": meta["scene"], "format": meta["format"], "dma": meta["dma"], "schedule": meta["schedule"],
               "cycles": res.cycles, "cycles_per_manifold_pass": res.cycles / mp, "stall_cycles": res.stalls,
               "bubble_cycles": res.bubbles, "issued": res.issued, "status": res.status, "rejected": res.rejected,
               "bytes_in": res.bytes_in, "bytes_out": res.bytes_out, "bytes_per_manifold": meta["bytes_per_manifold"],
               "records_compared": sb.compared, "fp_events": events,
               "sim_cycles": sim_cycles, "wall_s": wall, "cpu_s": cpu,
               "sim_cycles_per_s": sim_cycles / wall if wall > 0 else 0.0,
               "transaction_level": st.batches is not None}
    summary["cycle_lower_bound"] = meta.get("cycle_lower_bound")
    dut._log.info("cosim %s", json.dumps(summary))
    Path(os.environ["CASE_FILE"]).with_suffix(".result.json").write_text(json.dumps(summary, indent=1))
    if os.environ.get("BODY_OUT_FILE"):
        Path(os.environ["BODY_OUT_FILE"]).write_bytes(res.body_out)


@cocotb.test()
async def run_step_expect_mismatch(dut) -> None:
    """For a kernel built with an injected bug: run until the scoreboard's first mismatch and write what it
    reported (message, record index and that record's pass kind, iteration, slot) to ``<case>.mismatch.json``;
    the pytest side judges it. A step that ends without a mismatch writes ``caught: false``."""
    await _expect_mismatch(dut, await _start_step(dut))


@cocotb.test()
async def run_step_bursts_expect_mismatch(dut) -> None:
    """``run_step_expect_mismatch`` on the transaction-level bench (the batch scoreboard)."""
    await _expect_mismatch(dut, await _start_step(dut, transaction_level=True))


async def _expect_mismatch(dut, st: _Step) -> None:
    e = st.sb.exp
    try:
        await st.run()
        report: dict = {"caught": False, "records_compared": st.sb.compared}
    except AssertionError as err:
        k = st.sb.compared  # the record being compared when the scoreboard stopped
        report = {"caught": True, "message": str(err), "record": k, "cycle": st.sb.cycle, "kind": int(e.kind[k]),
                  "iteration": int(e.iteration[k]), "slot": int(e.slot[k])}
    dut._log.info("scoreboard: %s", json.dumps(report))
    Path(os.environ["CASE_FILE"]).with_suffix(".mismatch.json").write_text(json.dumps(report, indent=1))


def _prepare_case(path: Path, scene: str, params: dict, fmt_name: str, schedule_kind: str, dma: str,
                  seed: int, idle: float, backpressure: float, iterations: int = 4) -> dict:
    """Capture the scene, run the golden model and write the case (``sim.drive.cocotb_step.write_case``) with the
    stall probabilities (and the floating-point events the golden model counts)."""
    from models import scenes
    from models.setup.constraints import body_table, setup_constraints
    from models.timing.platforms import get_preset
    from models.golden.integrator import IntegrationParams
    from models.kernel.kernel_job import KernelJob
    from models.golden.contact_solver import SolverParams
    from models.order.manifold_schedule import make_schedule
    from sim.drive.cocotb_step import write_case
    from sim.drive.kernel_step import golden_step

    fmt = parse_format(fmt_name)
    frame = scenes.capture_frame(scene, **params)
    bodies = body_table(frame).rounded(fmt)
    cons = setup_constraints(frame, body_table(frame)).rounded(fmt)
    schedule = make_schedule(schedule_kind, cons, bodies.dynamic, window=64)
    job = KernelJob(fmt, bodies, cons, schedule, SolverParams(iterations=iterations),
                    IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))
    return write_case(path, job, golden_step(job), get_preset(dma), Path(scene).stem, seed, schedule_kind,
                      {"idle": idle, "backpressure": backpressure})


CASES = [
    ("stack", {"n": 10}, "fp32", "hazard", "zcu102", 0.2, 0.2),
    ("incline", {}, "fp32", "pybullet", "ideal", 0.2, 0.2),
    ("pile", {"nx": 6, "ny": 6, "nz": 6}, "fp32", "hazard", "zcu102", 0.1, 0.3),
]


def _cosim(testcase: str, scene: str, params: dict, fmt_name: str, schedule_kind: str, dma: str, idle: float,
           bp: float, friction_sign_bug: bool = False, compile_profile: str = "quick", bursts: bool = False,
           corrupt: tuple[int, int] | None = None) -> Path:
    """Prepare the case, build the kernel for it (``friction_sign_bug``: the friction pipe with the wrong sign,
    in a build of its own; ``compile_profile``: a key of ``sim.compile.kernel_build.COMPILE_PROFILES``, "o0" for a short
    run) and run the cocotb test ``testcase``; returns the case file. With ``WAVES=1`` the FST and its GTKWave
    save file are ``build/cocotb/<build>_waves/<case>.fst`` / ``.gtkw`` (printed)."""
    from sim.drive.cocotb_run import BUILD_ROOT, run_kernel_cocotb, run_kernel_cocotb_bursts, test_seed

    seed = test_seed()
    case_name = f"{Path(scene).stem}-{fmt_name}-{schedule_kind}-{dma}" + ("-bursts" if bursts else "")
    if friction_sign_bug:
        case_name += "-friction_sign_bug"
    if corrupt is not None:
        case_name += "-corrupt"
    case_dir = BUILD_ROOT / "cases"
    case_dir.mkdir(parents=True, exist_ok=True)
    case_file = case_dir / f"{case_name}.npz"
    for suffix in (".result.json", ".mismatch.json"):  # never judge a stale report
        case_file.with_suffix(suffix).unlink(missing_ok=True)
    meta = _prepare_case(case_file, scene, params, fmt_name, schedule_kind, dma, seed, idle, bp)
    if corrupt is not None:  # flip the lowest bit of one expected word: the scoreboard must name that record
        with np.load(case_file, allow_pickle=False) as npz:
            arrays = dict(npz)
        arrays["words"][corrupt] ^= np.uint64(1)
        np.savez(case_file, **arrays)
    words = meta["inertia_words"]  # the kernel build that runs the case: its body-in record's inverse inertia
    print(f"{scene}: {meta['num_bodies']} bodies, {meta['num_manifolds']} manifolds, {meta['passes']} passes, "
          f"{words} inverse-inertia words per body")
    env = {"CASE_FILE": str(case_file)}
    if bursts:
        env["TRACE_FILE"] = str(case_file.with_suffix(".trace.bin"))
        run_kernel_cocotb_bursts("test_kernel_cosim", fmt_name, dma, seed, env, testcase=[testcase],
                                 waves_name=case_name, inertia_words=words,
                                 friction_words=meta.get("friction_words", 0))
    else:
        run_kernel_cocotb("test_kernel_cosim", fmt_name, dma, seed, env, testcase=[testcase],
                          friction_sign_bug=friction_sign_bug, compile_profile=compile_profile, waves_name=case_name,
                          inertia_words=words)
    return case_file


@pytest.mark.parametrize("scene,params,fmt_name,schedule_kind,dma,idle,bp", CASES,
                         ids=[f"{c[0]}-{c[2]}-{c[3]}-{c[4]}" for c in CASES])
def test_kernel_cosim(scene, params, fmt_name, schedule_kind, dma, idle, bp) -> None:
    """The checks the cocotb test made, read back from its result: every record compared, status 0, the golden
    model's event counts, no fewer cycles than the cycle model's lower bound."""
    case_file = _cosim("run_step", scene, params, fmt_name, schedule_kind, dma, idle, bp)
    result = json.loads(case_file.with_suffix(".result.json").read_text())
    print(json.dumps(result, indent=1))
    with np.load(case_file, allow_pickle=False) as case:
        meta = json.loads(str(case["meta"]))
    assert result["records_compared"] == meta["num_manifolds"] * meta["passes"] > 0
    assert result["status"] == 0 and result["rejected"] == 0 and result["issued"] == result["records_compared"]
    assert result["fp_events"] == meta["fp_events"] == dict.fromkeys(EVENT_NAMES, 0)  # fp32: no event
    assert result["cycles"] >= meta["cycle_lower_bound"] > 0


# a world file of rotated non-cube boxes in Bullet 2's convention: every dynamic body's R diag(1/I) R^T a full
# symmetric 3x3, so its case runs on the 6-word build (IINV_W = 6); frame order, the ideal DMA preset (no DDR cap)
ROTATED_WORLD = str(Path(__file__).resolve().parents[1] / "docs" / "rotated_boxes_world.py")
BURST_CASES = [
    ("pile", {"nx": 6, "ny": 6, "nz": 6}, "fp32", "hazard", "zcu102", 3),
    (ROTATED_WORLD, {}, "fp32", "pybullet", "ideal", 6),
]


@pytest.mark.parametrize("scene,params,fmt_name,schedule_kind,dma,inertia_words", BURST_CASES,
                         ids=[f"{Path(c[0]).stem}-{c[2]}-{c[3]}-{c[4]}" for c in BURST_CASES])
def test_kernel_cosim_bursts(scene, params, fmt_name, schedule_kind, dma, inertia_words) -> None:
    """The transaction-level bench (bursts through the DMA models, the trace checked in batches): the same checks
    as the cycle-level test, every record against the golden model, and every record retired once; the kernel
    build is the case's (``inertia_words`` per body-in record: 6 for the rotated boxes, whose off-diagonal inverse
    inertia is non-zero)."""
    from sim.compare.trace_bits import read_trace

    from models.kernel.stream_format import trace_record_bytes, unpack_body_table

    case_file = _cosim("run_step_bursts", scene, params, fmt_name, schedule_kind, dma, 0.0, 0.0, bursts=True)
    result = json.loads(case_file.with_suffix(".result.json").read_text())
    print(json.dumps(result, indent=1))
    assert result["transaction_level"]
    fmt = parse_format(fmt_name)
    trace = read_trace(case_file.with_suffix(".trace.bin"), fmt, trace_record_bytes(fmt))
    with np.load(case_file, allow_pickle=False) as case:
        meta = json.loads(str(case["meta"]))
        assert meta["inertia_words"] == inertia_words, meta["inertia_words"]
        if inertia_words == 6:  # the symmetric product is exercised: an off-diagonal word of a dynamic body
            bodies = unpack_body_table(fmt, case["body_in"], inertia_words=6)
            assert np.any(bodies.inv_inertia[bodies.inv_mass > 0, 3:] != 0), "no off-diagonal inverse inertia"
        assert np.array_equal(trace.words, case["words"]) and np.array_equal(trace.slot, case["slot"])
    assert np.all(np.diff(trace.cycle.astype(np.int64)) >= 1), "two trace records stamped with the same cycle"


def test_batch_scoreboard_names_record_field_and_cycle() -> None:
    """A mismatch injected into the expected trace (one bit of one word of a record in the middle of the run): the
    batch scoreboard must stop there and name the record, its field and the cycle it retired in (the cycle stamped
    beside that record in the bench's trace, written to the trace file)."""
    from sim.compare.trace_bits import read_trace

    from cocotb_tests.tb.scoreboard import FIELDS
    from models.kernel.stream_format import trace_record_bytes

    record, field = 2345, FIELDS.index("wB.y")
    case_file = _cosim("run_step_bursts_expect_mismatch", "pile", {"nx": 6, "ny": 6, "nz": 6}, "fp32", "hazard",
                       "zcu102", 0.0, 0.0, bursts=True, corrupt=(record, field))
    report = json.loads(case_file.with_suffix(".mismatch.json").read_text())
    print(json.dumps(report, indent=1))
    assert report["caught"], f"the injected mismatch went undetected ({report['records_compared']} records compared)"
    fmt = parse_format("fp32")
    trace = read_trace(case_file.with_suffix(".trace.bin"), fmt, trace_record_bytes(fmt))
    cycle = int(trace.cycle[record])
    assert report["record"] == record and report["cycle"] == cycle, report
    msg = report["message"]
    assert re.match(rf"cycle {cycle}: retire #{record}: .*: body B field wB\.y: got (0x[0-9a-f]+) .*, "
                    r"expected (0x[0-9a-f]+) ", msg), msg
    got, want = (int(v, 16) for v in re.findall(r"(0x[0-9a-f]+) \(", msg))
    assert got ^ want == 1 and got == int(trace.words[record, field])


def test_batch_scoreboard_checks_every_record() -> None:
    """Without a simulator: records fed in bench batches (16, then a partial one) and checked in chunks of 64; a
    difference in any field of any record (here a word, then the slot of the last record, then one record too many)
    raises with that record, field and its retire cycle; identical records pass and are all counted."""
    from cocotb_tests.tb.scoreboard import FIELDS, BatchTraceScoreboard, ExpectedTrace

    from models.formats.number_format import FP32

    rng = np.random.default_rng(7)
    n = 200
    exp = ExpectedTrace(kind=np.repeat([0, 1], n // 2), iteration=np.zeros(n, np.int64), slot=np.arange(n),
                        manifold=np.arange(n), body_a=np.zeros(n, np.int64), body_b=np.ones(n, np.int64),
                        words=rng.integers(0, 1 << 32, (n, 16), dtype=np.uint64))
    cycles = 1000 + 3 * np.arange(n + 1)

    def bench_records(words: np.ndarray, slot: np.ndarray, kind: np.ndarray, cyc: np.ndarray) -> bytes:
        out = bytearray()
        for w, s_, k, c in zip(words, slot, kind, cyc):
            value = sum(int(x) << (32 * i) for i, x in enumerate(w)) | (int(s_) << 512) | (int(k) << 560)
            out += value.to_bytes(72, "little") + int(c).to_bytes(8, "little")
        return bytes(out)

    def run(words, slot, kind, count=n) -> BatchTraceScoreboard:
        sb = BatchTraceScoreboard(FP32, exp, chunk=64)
        raw = bench_records(words[:count], slot[:count], kind[:count], cycles[:count])
        for start in range(0, count, 16):
            m = min(16, count - start)
            sb.take(raw[start * 80:(start + m) * 80], m)
        sb.flush()
        return sb

    assert run(exp.words, exp.slot, exp.kind).complete
    bad = exp.words.copy()
    bad[137, 9] ^= np.uint64(1 << 31)
    with pytest.raises(AssertionError, match=rf"^cycle {cycles[137]}: retire #137: friction pass, .*body A field "
                                             rf"{re.escape(FIELDS[9])}: got"):
        run(bad, exp.slot, exp.kind)
    slot = exp.slot.copy()
    slot[n - 1] = 5
    with pytest.raises(AssertionError, match=rf"^cycle {cycles[n - 1]}: retire #{n - 1}: .*: slot is 5, expected"):
        run(exp.words, slot, exp.kind)
    extra = np.concatenate([exp.words, exp.words[:1]])
    with pytest.raises(AssertionError, match=rf"^cycle {cycles[n]}: unexpected extra trace record #{n}"):
        run(extra, np.append(exp.slot, 0), np.append(exp.kind, 0), count=n + 1)


def test_scoreboard_catches_friction_sign_bug() -> None:
    """The kernel built with the friction-sign bug (each friction row's velocity update applied with the wrong
    sign): the scoreboard must stop at the first update the bug affects, the first friction-pass record
    (iteration 0, slot 0), and name the field with both values; every contact-pass record before it matches.
    In the stack that record (manifold 0: the ground as body A, the bottom cube as B) has non-zero friction
    impulses, so the bug shows there, on body B and on the second tangent row's impulse (computed after the
    first row's wrong update). Built at -O0: a short run (it stops at the mismatch, ~1,700 cycles in)."""
    from cocotb_tests.tb.scoreboard import FIELDS

    case_file = _cosim("run_step_expect_mismatch", "stack", {"n": 10}, "fp32", "hazard", "zcu102", 0.2, 0.2,
                       friction_sign_bug=True, compile_profile="o0")
    report = json.loads(case_file.with_suffix(".mismatch.json").read_text())
    print(json.dumps(report, indent=1))
    assert report["caught"], f"the injected friction sign bug went undetected ({report['records_compared']} " \
                             "records compared, all equal to the golden model)"
    with np.load(case_file, allow_pickle=False) as case:
        first_friction = int(np.flatnonzero(case["kind"] == 1)[0])
        golden = case["words"][first_friction]
    where = (report["record"], report["kind"], report["iteration"], report["slot"])
    assert where == (first_friction, 1, 0, 0), \
        f"caught at retire #{report['record']} (kind {report['kind']}, iteration {report['iteration']}, slot " \
        f"{report['slot']}), not at the first friction-pass record #{first_friction}: {report['message']}"
    msg = report["message"]
    m = re.search(r"friction pass, iteration 0, slot 0, .*: body [AB-] field (\S+): got (0x[0-9a-f]+) \(.+\), "
                  r"expected (0x[0-9a-f]+) \(.+\)$", msg)
    assert m, f"scoreboard message does not name the record, field and both values: {msg}"
    field, got, want = m.group(1), int(m.group(2), 16), int(m.group(3), 16)
    assert field in FIELDS and got != want
    assert want == int(golden[FIELDS.index(field)]), "the expected value is not the golden model's"


@pytest.mark.parametrize("fmt_name,dma", [("fp32", "zcu102"), ("bf16", "ideal")])
def test_gtkwave_save_file_names_design_signals(tmp_path, fmt_name, dma) -> None:
    """Every trace of the kernel's ``.gtkw`` is a signal the RTL declares in that scope, with the range it has
    in that build (e.g. s_axis_cons_TDATA follows CONS_W), and the file reads back trace for trace."""
    from sim.drive import gtkwave_save as gs

    from sim.drive.cocotb_run import kernel_cocotb_build

    params = kernel_cocotb_build(fmt_name, dma).parameters
    groups = gs.kernel_groups(params)
    save = gs.write_kernel_save_file(tmp_path / "k.fst", parameters=params)
    assert save == tmp_path / "k.gtkw"
    text = save.read_text()
    assert f'[dumpfile] "{tmp_path / "k.fst"}"' in text and f'[savefile] "{save}"' in text
    traces = gs.save_file_traces(text)
    assert traces == [t.path for g in groups for t in g.traces]
    assert [g.name for g in groups] == ["Control", "Pipeline", "DMA streams", "Registers (AXI4-Lite)"]
    top = gs.KERNEL_TOP
    declared = {f"{top}.{inst}" if inst else top: gs.rtl_signals(gs.RTL_DIR / rtl_file, params)
                for _, parts in gs.KERNEL_LAYOUT for inst, rtl_file, _ in parts}
    assert {f"{top}.u_seq", f"{top}.u_seq.u_hazards", f"{top}.u_seq.u_integrate"} <= set(declared)
    for path in traces:
        scope, leaf = path.split("[")[0].rsplit(".", 1)
        rng = declared[scope].range(leaf)
        # GTKWave's name: [msb:lsb] on a vector, [msb] on a one-bit one (Verilator's [0:0])
        want = "" if rng is None else f"[{rng[0]}]" if rng[0] == rng[1] else f"[{rng[0]}:{rng[1]}]"
        assert path == f"{scope}.{leaf}{want}", path
    cons_w = params["CONS_W"]
    assert f"{top}.s_axis_cons_TDATA[{cons_w - 1}:0]" in traces
    for name in ("ap_clk", "ap_start", "ap_done", "ap_idle", "interrupt", "s_axi_control_AWVALID", "trace_valid",
                 "s_axis_body_TVALID", "m_axis_body_TREADY", "u_seq.issue", "u_seq.retire", "u_seq.hazard",
                 "u_seq.l_issue"):
        # a one-lane vector ([LANES-1:0] = [0:0]) is one bit to GTKWave: name[0]
        assert f"{top}.{name}" in traces or f"{top}.{name}[0]" in traces, name


def test_gtkwave_save_file_matches_fst() -> None:
    """Against a real dump, when there is one (a ``WAVES=1`` run of the fp32 kernel): every trace of the save file
    is a name GTKWave gives a variable of the FST (read from its hierarchy block; the compiled harness's dump is
    checked on every run in sim/tests/test_gtkwave_save.py)."""
    from sim.drive import gtkwave_save as gs
    from sim.drive.cocotb_run import BUILD_ROOT, kernel_cocotb_build

    fsts = sorted((BUILD_ROOT / "pgs_kernel_e8m23_c512_waves").glob("*.fst"), key=lambda f: f.stat().st_mtime)
    if not fsts:
        pytest.skip("no FST (run WAVES=1 .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack)")
    names = gs.fst_signal_names(fsts[-1])
    traces = [t.path for g in gs.kernel_groups(kernel_cocotb_build("fp32", "zcu102").parameters) for t in g.traces]
    missing = [t for t in traces if t not in names]
    assert not missing, f"not in {fsts[-1]}: {missing}"


def test_cocotb_driver_runs_make_sim(tmp_path) -> None:
    """``make sim DRIVER=cocotb`` on the stack, end to end with its report: bit-exact, every record compared, the
    run directory given relative to the repository as ``make sim``'s default is (the simulator runs in the bench's
    build directory, so the case must reach it by an absolute path); the transaction-level bench of the suite."""
    import subprocess
    import sys

    repo = Path(__file__).resolve().parents[1]
    out = Path(os.path.relpath(tmp_path / "sim", repo))
    cmd = [sys.executable, "-m", "sim.run", "--scene", "stack", "--iters", "2", "--driver", "cocotb", "--out",
           str(out), "--converged-budget", "5", "--exact-budget", "5"]
    proc = subprocess.run(cmd, cwd=repo, capture_output=True, text=True, timeout=1800)
    print(proc.stdout[-3000:])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    report = json.loads(next((repo / out).glob("*/report.json")).read_text())
    bits = report["bit-exactness (RTL kernel against the golden model, same format)"]
    assert bits["bits differing from the golden model (must be 0)"] == 0 and bits["first mismatch"] == "none"
    assert bits["trace records compared"] == report["schedule"]["manifold-passes"] > 0


@pytest.mark.parametrize("argv", [["--waves"], ["--stall-permille", "10"], ["--record-window", "1024"],
                                  ["--body-bits", "256"]])
def test_cocotb_driver_rejects_what_it_does_not_model(tmp_path, capsys, argv) -> None:
    """``make sim DRIVER=cocotb`` runs the streaming kernel without stalls or waveforms: other options end the run
    with one error line and exit status 2, before any frame is captured or anything written."""
    from sim import run

    assert run.main(["--scene", "stack", "--driver", "cocotb", "--out", str(tmp_path), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith("error: DRIVER=cocotb runs the streaming kernel"), err
    assert not any(tmp_path.iterdir())
