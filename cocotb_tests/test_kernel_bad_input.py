"""Bad input to the RTL kernel, in cocotb through the host driver and the AXI DMA model.

One scenario per case of the bad-input catalogue (``models/kernel/bad_input.py``) that a co-simulation can make. Each
scenario is a list of steps run one after the other on one kernel *without a reset in between* (after a
step the host only clears the sticky status flags it has read, W1C): one or more bad steps, then a good one.
Every step must end (ap_done within a cycle budget, else the host raises), and its trace (lock-step
scoreboard), body-out stream, status register (the case's error code), issued and rejected counts must equal
the kernel's documented response (``rtl/README.md``, "Bad input") as the golden model predicts it
(``tb.bad_input``): the rejected manifold-passes left out, frozen bodies passed through, every other body
bit-exact; the good step after the error bit-exact with the plain golden model. The scenes are the 10-cube stack (11
bodies, 10 manifolds) in fp32, hazard order, 2 iterations.

The scenarios run in one simulator process (one cocotb test each, ``bad_input_scenario``, parametrized) on the
kernel build of ``test_kernel_cosim.py`` (``build/cocotb/pgs_kernel_e8m23_c512``); each pytest case reports
its scenario's result. Random stream gaps and backpressure are seeded (``SEED=<n>`` reproduces a run).

    .venv/bin/python -m pytest cocotb_tests/test_kernel_bad_input.py -s          # all scenarios
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import cocotb
import numpy as np
import pytest

from models.kernel.bad_input import CATALOGUE, BadInputCase

FMT, DMA, ITERATIONS = "fp32", "zcu102", 2
TIMEOUT_CYCLES = 100_000
IDLE, BACKPRESSURE = 0.1, 0.2
MAX_BODIES = 65536  # the kernel's default parameter
UNMAPPED_READ, UNMAPPED_WRITE = 0xB0, 0xF4

# the catalogue's cases this co-simulation makes (each scenario's builder is below)
SCENARIOS: dict[str, BadInputCase] = {c.name: c for c in CATALOGUE if c.cosim}


def _case_dir() -> Path:
    from sim.drive.cocotb_run import BUILD_ROOT

    return BUILD_ROOT / "cases"


def _case_file(name: str) -> Path:
    return _case_dir() / f"bad_input-{name}.npz"


# ------------------------------------------------------------------------------------------------------------
# cocotb side
# ------------------------------------------------------------------------------------------------------------
async def _run(dut: Any, name: str) -> list[dict]:
    from cocotb.triggers import ClockCycles, select
    from tb import bad_input as bi
    from tb.host_driver import AP_CTRL, STATUS, KernelHost
    from tb.scoreboard import TraceScoreboard

    from models.timing.platforms import get_preset
    from models.formats.number_format import parse_format

    steps, meta = bi.load_steps(_case_file(name))
    fmt = parse_format(meta["format"])
    host = KernelHost(dut, get_preset(meta["dma"]), meta["seed"], idle_prob=IDLE, backpressure_prob=BACKPRESSURE)
    await host.reset()
    reports = []
    for step in steps:
        a = step.args
        await host.program(fmt, a["num_bodies"], a["num_manifolds"], a["iterations"], a["dt"], tuple(a["gravity"]),
                           a["damping"], a["options"])
        streams = (step.body_in.tobytes(), [p.tobytes() for p in step.passes], int(step.body_out.size))
        where = f"{name}/{step.label}"
        if step.action == "unmapped":
            for resp in (await host.axil.read(UNMAPPED_READ, 4), await host.axil.write(UNMAPPED_WRITE, b"\xff" * 4)):
                assert int(resp.resp) == 2, f"{where}: unmapped access answered {resp.resp}, not SLVERR"
        if step.action == "reset":
            feeder = await host.begin_step(*streams, TIMEOUT_CYCLES)
            await ClockCycles(host.clock, step.action_cycle)
            issued_before = int(await host.read_reg(0x78))
            await host.reset(dma=True)
            feeder.cancel()
            await ClockCycles(host.clock, 8)
            ctrl, status = await host.read_reg(AP_CTRL), await host.read_reg(STATUS)
            assert ctrl == 0x4 and status == 0, f"{where}: after the reset AP_CTRL {ctrl:#x} status {status:#x}"
            assert 0 < issued_before < step.issued, f"{where}: reset not in the middle (issued {issued_before})"
            reports.append({"step": step.label, "issued before the reset": issued_before, "AP_CTRL": ctrl})
            continue
        sb = TraceScoreboard(dut, fmt, step.trace)

        async def step_run() -> Any:
            feeder = await host.begin_step(*streams, TIMEOUT_CYCLES)
            if step.action == "start_busy":
                await ClockCycles(host.clock, step.action_cycle)
                await host.write_reg(AP_CTRL, 0x1)
            return await host.finish_step(feeder, *streams, TIMEOUT_CYCLES)

        try:
            _, res = await select(sb.monitor(), step_run())  # the monitor only ever ends by raising
        except AssertionError as err:
            raise AssertionError(f"{where}: {err}") from None
        assert sb.complete, f"{where}: trace {sb.compared} records, {step.trace.words.shape[0]} expected"
        got = (res.status, res.issued, res.rejected)
        assert got == (step.status, step.issued, step.rejected), \
            f"{where}: (status, issued, rejected) = ({res.status:#x}, {res.issued}, {res.rejected}), expected " \
            f"({step.status:#x}, {step.issued}, {step.rejected})"
        want = step.body_out.tobytes()
        if res.body_out != want:
            got_b = np.frombuffer(res.body_out.ljust(len(want), b"\0"), np.uint8)[:len(want)]
            bad = np.flatnonzero(got_b != step.body_out)
            first = int(bad[0]) if bad.size else len(want)
            raise AssertionError(f"{where}: body-out differs from the golden model at byte {first} (body "
                                 f"{first // meta['body_out_record_bytes']}); {len(res.body_out)} bytes, "
                                 f"{len(want)} expected")
        await ClockCycles(host.clock, 64)  # no second run may follow (ap_start written while busy)
        ctrl = await host.read_reg(AP_CTRL)
        assert ctrl & 0x5 == 0x4, f"{where}: AP_CTRL {ctrl:#x} after the step (must be idle, ap_start clear)"
        if res.status:
            await host.write_reg(STATUS, 0xFFFFFFFF)  # the host clears the flags it has seen
            assert await host.read_reg(STATUS) == 0
        reports.append({"step": step.label, "cycles": res.cycles, "status": f"{res.status:#x}", "issued": res.issued,
                        "rejected": res.rejected, "records compared": sb.compared, "body bytes": len(want)})
    return reports


@cocotb.test()
@cocotb.parametrize(scenario=list(SCENARIOS))
async def bad_input_scenario(dut: Any, scenario: str) -> None:
    """Run the steps of one scenario; write ``<case>.result.json`` (ok, per-step report or the error)."""
    out = _case_file(scenario).with_suffix(".result.json")
    t0 = time.perf_counter()
    try:
        reports = await _run(dut, scenario)
    except (AssertionError, TimeoutError) as err:
        out.write_text(json.dumps({"ok": False, "error": f"{type(err).__name__}: {err}"}, indent=1))
        raise
    out.write_text(json.dumps({"ok": True, "steps": reports, "wall_s": time.perf_counter() - t0}, indent=1))


# ------------------------------------------------------------------------------------------------------------
# pytest side: the scenarios' steps
# ------------------------------------------------------------------------------------------------------------
def _manifold(job: Any, a: int, b: int) -> int:
    """The manifold joining bodies a and b."""
    ba, bb = job.cons.body_a, job.cons.body_b
    hit = np.flatnonzero(((ba == a) & (bb == b)) | ((ba == b) & (bb == a)))
    assert hit.size == 1, f"no single manifold between bodies {a} and {b}"
    return int(hit[0])


def _scenario_steps(case: BadInputCase, job: Any, sb: Any) -> list[Any]:
    """The steps of ``case``'s scenario (bad ones, then the good step) from the stack job and its StepBuilder;
    each bad step's status is the case's error alone."""
    from tb import bad_input as bi
    from tb.scoreboard import expected_trace

    from models.setup.constraints import ConstraintSet

    good = sb.step("good")
    nb = job.bodies.num_bodies
    cons, bodies = _copy(job.cons), job.bodies.copy()
    nm = len(sb.slots)
    name = case.name
    steps: list[Any]
    if name == "nonfinite_constraint":
        cons.normal[_manifold(job, 4, 5), 0] = np.nan
        cons.bias[_manifold(job, 7, 8), 2] = np.inf
        steps = [sb.step("NaN and inf in constraint records", case.status, cons=cons)]
    elif name == "nonfinite_body":
        bodies.position[3, 1] = np.nan
        bodies.angular_velocity[7, 2] = -np.inf
        steps = [sb.step("NaN and -inf in body records", case.status, bodies=bodies)]
    elif name == "body_index":
        cons.body_b[_manifold(job, 2, 3)] = nb + 5
        m = _manifold(job, 6, 7)
        cons.body_a[m] = cons.body_b[m]
        steps = [sb.step("body index out of range, same body twice", case.status, cons=cons)]
    elif name == "zero_inverse_mass":
        bodies.inv_mass[1] = 0.0
        steps = [sb.step("inverse mass 0", case.status, bodies=bodies)]
    elif name == "negative_inverse_mass":
        bodies.inv_mass[4] = -1.0
        bodies.inv_inertia[8, 1] = -2.0
        steps = [sb.step("negative inverse mass and inertia", case.status, bodies=bodies)]
    elif name == "tlast_early":
        short = [p.copy() for p in good.passes]
        short[1] = short[1][:4 * sb.record_bytes(1)]
        cut = [p.copy() for p in good.passes]
        cut[0] = cut[0][:-sb.beat_bits // 8]  # the last record of pass 0 loses its last beat
        steps = [sb.step("pass 1 has 4 of 10 records", case.status, passes=short,
                         extra_drops={k: 1 for k in range(4, nm)}),
                 sb.step("pass 0's last record cut short", case.status, passes=cut, extra_drops={nm - 1: 0})]
    elif name == "tlast_late":
        long = [p.copy() for p in good.passes]
        long[0] = np.concatenate([long[0], long[0][:2 * sb.record_bytes(0)]])
        long[-1] = np.concatenate([long[-1], long[-1][-sb.record_bytes(len(long) - 1):]])
        steps = [sb.step("passes 0 and last too long", case.status, passes=long)]
    elif name == "body_tlast_early":
        rec = sb.layout.body_in_bytes
        steps = [sb.step("body stream 2 bodies short", case.status, body_in=good.body_in[:-2 * rec],
                         missing_bodies=2),
                 sb.step("last body record cut short", case.status, body_in=good.body_in[:-16],
                         cut_bodies=(nb - 1,))]
    elif name == "body_tlast_late":
        rec = sb.layout.body_in_bytes
        steps = [sb.step("body stream a body long", case.status,
                         body_in=np.concatenate([good.body_in, good.body_in[:rec]]))]
    elif name == "zero_manifolds":
        none = ConstraintSet(**{f.name: getattr(job.cons, f.name)[:0] for f in dataclasses.fields(ConstraintSet)})
        free = dataclasses.replace(job, cons=none, schedule=np.zeros(0, dtype=np.int64))
        step = bi.StepBuilder(free, sb.beat_bits).step("num_manifolds 0", passes=[])
        steps = [step]
        assert case.status == 0
    elif name == "bad_argument":
        args = dict(good.args, num_bodies=MAX_BODIES + 1)
        empty = np.zeros(0, dtype=np.uint8)
        steps = [dataclasses.replace(good, label="num_bodies > MAX_BODIES", args=args, body_in=empty, passes=[],
                                     body_out=empty, trace=expected_trace(job.fmt, [], empty, empty),
                                     status=case.status, issued=0, rejected=0)]
    elif name == "start_busy":
        steps = [dataclasses.replace(good, label="ap_start during the run", status=case.status,
                                     action="start_busy", action_cycle=300)]
    elif name == "reset_mid_run":
        steps = [dataclasses.replace(good, label="reset during the solve", action="reset", action_cycle=900)]
    elif name == "unmapped_axi":
        steps = [dataclasses.replace(good, label="unmapped accesses before the run", status=case.status,
                                     action="unmapped")]
    else:  # pragma: no cover
        raise KeyError(name)
    return steps + [good]


def _copy(cons: Any) -> Any:
    return dataclasses.replace(cons, **{f.name: getattr(cons, f.name).copy() for f in dataclasses.fields(cons)})


def _prepare(seed: int) -> dict[str, Path]:
    """Write every scenario's case file; returns them by name."""
    from tb import bad_input as bi

    from models import scenes
    from models.kernel import stream_format as sf
    from models.golden.contact_solver import SolverParams
    from models.timing.platforms import get_preset
    from models.formats.number_format import parse_format
    from models.kernel.kernel_job import KernelJob
    from sim.compile.kernel_build import default_window

    fmt, preset = parse_format(FMT), get_preset(DMA)
    frame = scenes.load_or_capture("stack", n=10)
    job = KernelJob.from_frame(frame, fmt, SolverParams(ITERATIONS), "hazard", default_window(fmt, preset.stream_bits))
    builder = bi.StepBuilder(job, preset.stream_bits)
    _case_dir().mkdir(parents=True, exist_ok=True)
    meta = {"format": FMT, "dma": DMA, "seed": seed,
            "body_out_record_bytes": sf.StreamLayout(fmt, preset.stream_bits).body_out_bytes}
    files = {}
    for name, case in SCENARIOS.items():
        path = _case_file(name)
        path.with_suffix(".result.json").unlink(missing_ok=True)  # never judge a stale report
        bi.save_steps(path, _scenario_steps(case, job, builder), meta)
        files[name] = path
    return files


@pytest.fixture(scope="module")
def scenario_results() -> dict[str, dict | None]:
    """Prepare every scenario and run them all in one simulator process; each one's result JSON (None: none)."""
    from sim.drive.cocotb_run import run_kernel_cocotb, test_seed

    seed = test_seed()
    t0 = time.monotonic()
    files = _prepare(seed)
    t1 = time.monotonic()
    try:
        run_kernel_cocotb("test_kernel_bad_input", FMT, DMA, seed, {})
    except SystemExit:  # cocotb's runner exits when a test failed; each scenario's JSON says which
        pass
    print(f"bad input: cases prepared in {t1 - t0:.1f} s, build and simulation {time.monotonic() - t1:.1f} s")
    out: dict[str, dict | None] = {}
    for name, path in files.items():
        res = path.with_suffix(".result.json")
        out[name] = json.loads(res.read_text()) if res.exists() else None
    return out


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_kernel_bad_input(scenario_results: dict[str, dict | None], scenario: str) -> None:
    res = scenario_results[scenario]
    assert res is not None, f"{scenario}: the cocotb test left no result (see the simulator log above)"
    assert res["ok"], f"{scenario} ({SCENARIOS[scenario].describe()}): {res['error']}"
    print(f"\n{scenario}: {SCENARIOS[scenario].describe()}\n" + "\n".join(json.dumps(s) for s in res["steps"]))

