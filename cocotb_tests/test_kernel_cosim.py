"""Co-simulation of one step: pybullet contacts through the AXI DMA model into the RTL kernel, in cocotb.

pytest prepares a case (scene frame, constraints, schedule, the packed streams of ``models/stream_format.py``
and the golden model's expected trace and body table) into an ``.npz``; the cocotb test ``run_step`` loads
DDR, programs the DMAs and the kernel over AXI4-Lite (``cocotb_tests/tb/host_driver.py``), starts it, and the
scoreboard (``cocotb_tests/tb/scoreboard.py``) compares every retired manifold-pass as it appears; the final body
table read back over S2MM is compared too. Random idle cycles on every MM2S stream and random backpressure on
S2MM are seeded (the seed is printed; ``SEED=<n>`` reproduces a run); results must be bit-identical whatever the
stalls.
The status register must read 0, no manifold-pass may be rejected, and the floating-point event counters must
equal the golden model's prediction (``cocotb_tests/tb/fp_events.py``; zero for these fp32 scenes).

The kernel's cycles must not beat the cycle model's lower bound (``models/cycle_model.py``, with the first body and
constraint transfers armed before ap_start, as this host arms them).

``test_scoreboard_catches_friction_sign_bug`` checks the checker: the kernel built with the friction-sign bug
(``KernelBuild(friction_sign_bug=True)``, a build of its own) must be stopped by the scoreboard at the first
friction-pass record (the cocotb test ``run_step_expect_mismatch`` catches the scoreboard's AssertionError and
reports it to pytest).

``WAVES=1`` writes ``build/cocotb/<build>_waves/<case>.fst`` and a GTKWave save file beside it,
``<case>.gtkw`` (control, DMA streams and pipeline signals grouped); both paths are printed.

    .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack      # one case
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

from models.number_format import EVENT_NAMES, parse_format

TIMEOUT_CYCLES = 2_000_000


@dataclass
class _Step:
    """One step set up in the simulator: the case (``.npz``), the host (DMA, DDR, AXI4-Lite) and the scoreboard."""

    case: Any
    meta: dict
    host: Any
    sb: Any

    async def run(self):
        """Run the step with the scoreboard watching the trace; the first mismatch raises its AssertionError."""
        from cocotb.triggers import select

        passes = [self.case[f"pass{p}"].tobytes() for p in range(self.meta["passes"])]
        run = self.host.run_step(self.case["body_in"].tobytes(), passes, int(self.case["body_out"].size),
                                 TIMEOUT_CYCLES)
        _, res = await select(self.sb.monitor(), run)  # the monitor only ever ends by raising
        return res


async def _start_step(dut) -> _Step:
    """Load the case of ``CASE_FILE``, reset the kernel and program its arguments."""
    from cocotb_tests.tb.host_driver import KernelHost
    from cocotb_tests.tb.scoreboard import ExpectedTrace, TraceScoreboard

    from models.dma_model import get_preset

    with np.load(os.environ["CASE_FILE"], allow_pickle=False) as npz:
        case = dict(npz)
    meta = json.loads(str(case["meta"]))
    fmt = parse_format(meta["format"])
    host = KernelHost(dut, get_preset(meta["dma"]), meta["seed"], idle_prob=meta["idle"],
                      backpressure_prob=meta["backpressure"])
    expected = ExpectedTrace(case["kind"], case["iteration"], case["slot"], case["manifold"], case["body_a"],
                             case["body_b"], case["words"])
    step = _Step(case, meta, host, TraceScoreboard(dut, fmt, expected))
    await host.reset()
    await host.program(fmt, meta["num_bodies"], meta["num_manifolds"], meta["iterations"], meta["dt"],
                       tuple(meta["gravity"]), meta["damping"], meta["options"])
    return step


@cocotb.test()
async def run_step(dut) -> None:
    st = await _start_step(dut)
    case, meta, sb = st.case, st.meta, st.sb
    t0 = time.perf_counter()
    res = await st.run()
    wall = time.perf_counter() - t0
    assert res.status == 0, f"kernel status register {res.status:#x} (sticky error flags) after a good frame"
    assert res.rejected == 0, f"{res.rejected} manifold-passes rejected in a good frame"
    events = dict(zip(EVENT_NAMES, res.fp_events))
    assert events == meta["fp_events"], f"floating-point events {events}, the golden model predicts {meta['fp_events']}"
    assert sb.complete, f"trace: {sb.compared} records compared, {sb.exp.words.shape[0]} expected"
    assert res.cycles >= meta["cycle_lower_bound"], \
        f"{res.cycles:,} kernel cycles beat the cycle model's lower bound of {meta['cycle_lower_bound']:,}"
    want = case["body_out"].tobytes()
    if res.body_out != want:
        got_w = np.frombuffer(res.body_out.ljust(len(want), b"\0"), np.uint8)
        first = int(np.flatnonzero(got_w != case["body_out"])[0])
        raise AssertionError(f"body-out stream differs from the golden model at byte {first} "
                             f"(record {first // meta['body_out_record_bytes']}); got {len(res.body_out)} bytes")
    mp = meta["num_manifolds"] * meta["passes"]
    summary = {"scene": meta["scene"], "format": meta["format"], "dma": meta["dma"], "schedule": meta["schedule"],
               "cycles": res.cycles, "cycles_per_manifold_pass": res.cycles / mp, "stall_cycles": res.stalls,
               "bubble_cycles": res.bubbles, "bytes_in": res.bytes_in, "bytes_out": res.bytes_out,
               "bytes_per_manifold": meta["bytes_per_manifold"], "records_compared": sb.compared, "fp_events": events,
               "sim_cycles_per_s": sb.cycle / wall if wall > 0 else 0.0}
    summary["cycle_lower_bound"] = meta["cycle_lower_bound"]
    dut._log.info("cosim %s", json.dumps(summary))
    Path(os.environ["CASE_FILE"]).with_suffix(".result.json").write_text(json.dumps(summary, indent=1))


@cocotb.test()
async def run_step_expect_mismatch(dut) -> None:
    """For a kernel built with an injected bug: run until the scoreboard's first mismatch and write what it
    reported (message, record index and that record's pass kind, iteration, slot) to ``<case>.mismatch.json``;
    the pytest side judges it. A step that ends without a mismatch writes ``caught: false``."""
    st = await _start_step(dut)
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
    from cocotb_tests.tb.fp_events import predicted_events
    from cocotb_tests.tb.scoreboard import expected_trace

    from models import scenes
    from models import stream_format as sf
    from models.constraints import body_table, setup_constraints
    from models.contact_solver import SolverParams, pass_sequence, solve
    from models.dma_model import get_preset
    from models.integrator import IntegrationParams, integrate
    from models.schedule import make_schedule
    from models.kernel_job import KernelJob

    fmt = parse_format(fmt_name)
    preset = get_preset(dma)
    frame = scenes.capture_frame(scene, **params)
    bodies = body_table(frame).rounded(fmt)
    cons = setup_constraints(frame, body_table(frame)).rounded(fmt)
    schedule = make_schedule(schedule_kind, cons, bodies.dynamic, window=64)
    sp = SolverParams(iterations=iterations)
    records: list = []
    result = solve(bodies, cons, schedule, fmt, sp, trace=records.append)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    final = integrate(result.bodies, fmt, ip)
    events = predicted_events(KernelJob(fmt, bodies, cons, schedule, sp, ip)).as_dict()
    exp = expected_trace(fmt, records, cons.body_a, cons.body_b)
    layout = sf.StreamLayout(fmt, cons_beat_bits=preset.stream_bits)
    cons_stream = sf.pack_constraint_stream(fmt, cons, schedule, sp, beat_bits=preset.stream_bits)
    per_pass = np.split(cons_stream.data, np.flatnonzero(cons_stream.last)[:-1] + 1)
    body_in = sf.pack_body_table(fmt, bodies).data
    body_out = sf.pack_body_out(fmt, final).data
    meta = {"scene": scene, "format": fmt_name, "dma": dma, "schedule": schedule_kind, "seed": seed, "idle": idle,
            "backpressure": backpressure, "num_bodies": frame.num_bodies, "num_manifolds": frame.num_manifolds,
            "iterations": iterations, "passes": len(pass_sequence(sp)), "dt": frame.dt,
            "gravity": list(frame.gravity), "damping": 0.99, "options": 0,
            "body_out_record_bytes": layout.body_out_bytes, "bytes_per_manifold": layout.bytes_per_manifold(sp),
            "fp_events": events}
    meta["cycle_lower_bound"] = _cycle_lower_bound(fmt, bodies, cons, schedule, sp, frame, preset)
    np.savez(path, meta=np.array(json.dumps(meta)), kind=exp.kind, iteration=exp.iteration, slot=exp.slot,
             manifold=exp.manifold, body_a=exp.body_a, body_b=exp.body_b, words=exp.words, body_in=body_in,
             body_out=body_out, **{f"pass{p}": d for p, d in enumerate(per_pass)})
    return meta


CASES = [
    ("stack", {"n": 10}, "fp32", "hazard", "zcu102", 0.2, 0.2),
    ("incline", {}, "fp32", "pybullet", "ideal", 0.2, 0.2),
    ("pile", {"nx": 6, "ny": 6, "nz": 6}, "fp32", "hazard", "zcu102", 0.1, 0.3),
]


def _cosim(testcase: str, scene: str, params: dict, fmt_name: str, schedule_kind: str, dma: str, idle: float,
           bp: float, friction_sign_bug: bool = False, compile_profile: str = "quick") -> Path:
    """Prepare the case, build the kernel for it (``friction_sign_bug``: the friction pipe with the wrong sign,
    in a build of its own; ``compile_profile``: a key of ``sim.kernel_build.COMPILE_PROFILES``, "o0" for a short
    run) and run the cocotb test ``testcase``; returns the case file. With ``WAVES=1`` the FST and its GTKWave
    save file are ``build/cocotb/<build>_waves/<case>.fst`` / ``.gtkw`` (printed)."""
    from sim.cocotb_run import BUILD_ROOT, run_kernel_cocotb, test_seed

    seed = test_seed()
    case_name = f"{scene}-{fmt_name}-{schedule_kind}-{dma}"
    if friction_sign_bug:
        case_name += "-friction_sign_bug"
    case_dir = BUILD_ROOT / "cases"
    case_dir.mkdir(parents=True, exist_ok=True)
    case_file = case_dir / f"{case_name}.npz"
    for suffix in (".result.json", ".mismatch.json"):  # never judge a stale report
        case_file.with_suffix(suffix).unlink(missing_ok=True)
    meta = _prepare_case(case_file, scene, params, fmt_name, schedule_kind, dma, seed, idle, bp)
    print(f"{scene}: {meta['num_bodies']} bodies, {meta['num_manifolds']} manifolds, {meta['passes']} passes")
    run_kernel_cocotb("test_kernel_cosim", fmt_name, dma, seed, {"CASE_FILE": str(case_file)}, testcase=[testcase],
                      friction_sign_bug=friction_sign_bug, compile_profile=compile_profile, waves_name=case_name)
    return case_file


@pytest.mark.parametrize("scene,params,fmt_name,schedule_kind,dma,idle,bp", CASES,
                         ids=[f"{c[0]}-{c[2]}-{c[3]}-{c[4]}" for c in CASES])
def test_kernel_cosim(scene, params, fmt_name, schedule_kind, dma, idle, bp) -> None:
    case_file = _cosim("run_step", scene, params, fmt_name, schedule_kind, dma, idle, bp)
    print(case_file.with_suffix(".result.json").read_text())


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
    from sim import gtkwave_save as gs

    from sim.cocotb_run import kernel_cocotb_build

    params = kernel_cocotb_build(fmt_name, dma).parameters
    groups = gs.kernel_groups(params)
    save = gs.write_kernel_save_file(tmp_path / "k.fst", parameters=params)
    assert save == tmp_path / "k.gtkw"
    text = save.read_text()
    assert f'[dumpfile] "{tmp_path / "k.fst"}"' in text and f'[savefile] "{save}"' in text
    traces = gs.save_file_traces(text)
    assert traces == [t.path for g in groups for t in g.traces]
    assert [g.name for g in groups] == ["Control", "DMA streams", "Pipeline"]
    top = gs.KERNEL_TOP
    declared = {top: gs.rtl_signals(gs.RTL_DIR / "pgs_kernel.sv", params),
                f"{top}.u_seq": gs.rtl_signals(gs.RTL_DIR / "pgs_sequencer.sv", params)}
    for path in traces:
        scope, leaf = path.split("[")[0].rsplit(".", 1)
        rng = declared[scope].range(leaf)
        assert path == f"{scope}.{leaf}" + (f"[{rng[0]}:{rng[1]}]" if rng else ""), path
    cons_w = params["CONS_W"]
    assert f"{top}.s_axis_cons_TDATA[{cons_w - 1}:0]" in traces
    for name in ("ap_clk", "ap_start", "ap_done", "ap_idle", "interrupt", "s_axi_control_AWVALID", "trace_valid",
                 "s_axis_body_TVALID", "m_axis_body_TREADY", "u_seq.issue", "u_seq.retire", "u_seq.hazard",
                 "u_seq.l_issue"):
        # a one-lane vector ([LANES-1:0] = [0:0]) keeps its range in Verilator's dump
        assert f"{top}.{name}" in traces or f"{top}.{name}[0:0]" in traces, name


def test_gtkwave_save_file_matches_fst() -> None:
    """Against a real dump, when there is one (a ``WAVES=1`` run of the fp32 kernel) and ``fst2vcd`` (gtkwave
    package) is installed: every trace of the save file is in the FST's hierarchy."""
    from sim import gtkwave_save as gs
    from sim.cocotb_run import BUILD_ROOT, kernel_cocotb_build

    fsts = sorted((BUILD_ROOT / "pgs_kernel_e8m23_c512_waves").glob("*.fst"), key=lambda f: f.stat().st_mtime)
    if not fsts:
        pytest.skip("no FST (run WAVES=1 .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack)")
    names = gs.fst_signal_names(fsts[-1])
    if names is None:
        pytest.skip("fst2vcd (gtkwave package) not installed")
    traces = [t.path for g in gs.kernel_groups(kernel_cocotb_build("fp32", "zcu102").parameters) for t in g.traces]
    missing = [t for t in traces if t not in names]
    assert not missing, f"not in {fsts[-1]}: {missing}"


def _cycle_lower_bound(fmt: Any, bodies: Any, cons: Any, schedule: np.ndarray, sp: Any, frame: Any,
                       preset: Any) -> int:
    """Cycles the case cannot beat: the cycle model with the first transfers under way at ap_start."""
    from models.cycle_model import lower_bound
    from models.integrator import IntegrationParams
    from models.kernel_job import KernelJob

    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    return lower_bound(KernelJob(fmt, bodies, cons, schedule, sp, ip), preset, prefetched=True)
