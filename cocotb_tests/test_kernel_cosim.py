"""Co-simulation of one step: pybullet contacts through the AXI DMA model into the RTL kernel, in cocotb.

pytest prepares a case (scene frame, constraints, schedule, the packed streams of ``models/stream_format.py``
and the golden model's expected trace and body table) into an ``.npz``; the cocotb test ``run_step`` loads
DDR, programs the DMAs and the kernel over AXI4-Lite (``tb.host_driver``), starts it, and the scoreboard
(``tb.scoreboard``) compares every retired manifold-pass as it appears; the final body table read back over
S2MM is compared too. Random idle cycles on every MM2S stream and random backpressure on S2MM are seeded
(the seed is printed; ``SEED=<n>`` reproduces a run); results must be bit-identical whatever the stalls.

    .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack      # one case
    WAVES=1 .venv/bin/python -m pytest cocotb_tests/test_kernel_cosim.py -k stack   # + FST waveform
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import cocotb
import numpy as np
import pytest

from models.number_format import parse_format

HERE = Path(__file__).resolve().parent
TIMEOUT_CYCLES = 2_000_000


@cocotb.test()
async def run_step(dut) -> None:
    from tb.host_driver import KernelHost
    from tb.scoreboard import ExpectedTrace, TraceScoreboard

    from models.dma_model import get_preset

    case = np.load(os.environ["CASE_FILE"], allow_pickle=False)
    meta = json.loads(str(case["meta"]))
    fmt = parse_format(meta["format"])
    preset = get_preset(meta["dma"])
    host = KernelHost(dut, preset, meta["seed"], idle_prob=meta["idle"], backpressure_prob=meta["backpressure"])
    expected = ExpectedTrace(case["kind"], case["iteration"], case["slot"], case["manifold"], case["body_a"],
                             case["body_b"], case["words"])
    sb = TraceScoreboard(dut, fmt, expected)
    await host.reset()
    monitor = cocotb.start_soon(sb.monitor())
    await host.program(fmt, meta["num_bodies"], meta["num_manifolds"], meta["iterations"], meta["dt"],
                       tuple(meta["gravity"]), meta["damping"], meta["options"])
    passes = [case[f"pass{p}"].tobytes() for p in range(meta["passes"])]
    t0 = time.perf_counter()
    res = await host.run_step(case["body_in"].tobytes(), passes, int(case["body_out"].size), TIMEOUT_CYCLES)
    wall = time.perf_counter() - t0
    monitor.cancel()
    assert res.status == 0, f"kernel status register {res.status:#x} (sticky error flags) after a good frame"
    assert sb.complete, f"trace: {sb.compared} records compared, {expected.words.shape[0]} expected"
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
               "bytes_per_manifold": meta["bytes_per_manifold"], "records_compared": sb.compared,
               "sim_cycles_per_s": sb.cycle / wall if wall > 0 else 0.0}
    dut._log.info("cosim %s", json.dumps(summary))
    Path(os.environ["CASE_FILE"]).with_suffix(".result.json").write_text(json.dumps(summary, indent=1))


def _prepare_case(path: Path, scene: str, params: dict, fmt_name: str, schedule_kind: str, dma: str,
                  seed: int, idle: float, backpressure: float, iterations: int = 4) -> dict:
    from tb.scoreboard import expected_trace

    from models import scenes
    from models import stream_format as sf
    from models.constraints import body_table, setup_constraints
    from models.contact_solver import SolverParams, pass_sequence, solve
    from models.dma_model import get_preset
    from models.integrator import IntegrationParams, integrate
    from models.schedule import make_schedule

    fmt = parse_format(fmt_name)
    preset = get_preset(dma)
    frame = scenes.capture_frame(scene, **params)
    bodies = body_table(frame).rounded(fmt)
    cons = setup_constraints(frame, body_table(frame)).rounded(fmt)
    schedule = make_schedule(schedule_kind, cons, bodies.dynamic, window=64)
    sp = SolverParams(iterations=iterations)
    records: list = []
    result = solve(bodies, cons, schedule, fmt, sp, trace=records.append)
    final = integrate(result.bodies, fmt, IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))
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
            "body_out_record_bytes": layout.body_out_bytes, "bytes_per_manifold": layout.bytes_per_manifold(sp)}
    np.savez(path, meta=np.array(json.dumps(meta)), kind=exp.kind, iteration=exp.iteration, slot=exp.slot,
             manifold=exp.manifold, body_a=exp.body_a, body_b=exp.body_b, words=exp.words, body_in=body_in,
             body_out=body_out, **{f"pass{p}": d for p, d in enumerate(per_pass)})
    return meta


CASES = [
    ("stack", {"n": 10}, "fp32", "hazard", "zcu102", 0.2, 0.2),
    ("incline", {}, "fp32", "pybullet", "ideal", 0.2, 0.2),
    ("pile", {"nx": 6, "ny": 6, "nz": 6}, "fp32", "hazard", "zcu102", 0.1, 0.3),
]


@pytest.mark.parametrize("scene,params,fmt_name,schedule_kind,dma,idle,bp", CASES,
                         ids=[f"{c[0]}-{c[2]}-{c[3]}-{c[4]}" for c in CASES])
def test_kernel_cosim(scene, params, fmt_name, schedule_kind, dma, idle, bp) -> None:
    from cocotb_runner import BUILD_ROOT, run_cocotb, test_seed

    from models.dma_model import get_preset
    from sim.lint import rtl_files

    fmt = parse_format(fmt_name)
    preset = get_preset(dma)
    seed = test_seed()
    tag = f"pgs_kernel_e{fmt.exp_bits}m{fmt.man_bits}_c{preset.stream_bits}"
    case_dir = BUILD_ROOT / "cases"
    case_dir.mkdir(parents=True, exist_ok=True)
    case_file = case_dir / f"{scene}-{fmt_name}-{schedule_kind}-{dma}.npz"
    meta = _prepare_case(case_file, scene, params, fmt_name, schedule_kind, dma, seed, idle, bp)
    print(f"{scene}: {meta['num_bodies']} bodies, {meta['num_manifolds']} manifolds, {meta['passes']} passes")
    packages, modules = rtl_files()
    run_cocotb("pgs_kernel", packages + modules, "test_kernel_cosim", name=tag, seed=seed,
               parameters={"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits, "CONS_W": preset.stream_bits},
               extra_env={"CASE_FILE": str(case_file)}, testcase=["run_step"],
               public_vlt=HERE / "kernel" / "pgs_kernel_public.vlt")
    print(case_file.with_suffix(".result.json").read_text())
