"""cocotb bench of rtl/pgs_seq_integrate.sv (the sequencer's INTEG phase: every body through the integrate pipe, out on
m_body) against the golden model.

The bench plays the body RAM (a registered read of body rd_idx) over tables of random bodies: dynamic ones with random
velocities (some spinning fast enough for the angle clamp, some not at all: the 0/0 of the small-angle branch, an
invalid event), static ones (inverse mass 0) and bad ones (the RAM's flag);
m_body_tready drops at random, in stretches. Checked: the body-out stream, beat by beat: every body once, in index
order, a dynamic body integrated as models/golden/integrator.py integrates it (bit for bit, through
models/kernel/kernel_vectors.py), a static or bad body's record unchanged; TLAST on the last beat of the last body
only; `done` once the last beat is taken (at once for no body); the floating-point event counts equal the integrate
graph's software twin over the dynamic bodies; the reads never run ahead of the output FIFO's credits (at most
OUT_FIFO_DEPTH bodies between a read and its last beat). ``SEED=<n>`` reproduces a run.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import cocotb
import numpy as np

from tb.cycles import cycle, start, val

REPO = Path(__file__).resolve().parents[1]
BEAT = 128
FIFO_DEPTH = 8
IINV_W = 3


def bodies_table(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 14 + IINV_W) body words (float64) and the bad flags."""
    w = np.zeros((n, 14 + IINV_W))
    w[:, 0:3] = rng.uniform(-20, 20, (n, 3))
    q = rng.normal(size=(n, 4))
    w[:, 3:7] = q / np.linalg.norm(q, axis=1, keepdims=True)
    w[:, 7:10] = rng.normal(0, 3, (n, 3))
    w[:, 10:13] = rng.normal(0, 3, (n, 3)) * rng.choice([1.0, 1e-4, 60.0, 0.0], (n, 1), p=[0.7, 0.1, 0.1, 0.1])
    w[:, 13] = np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0.1, 2.0, n))  # static bodies
    w[:, 14:17] = rng.uniform(0.1, 2.0, (n, 3))
    return w, rng.random(n) < 0.1


@cocotb.test()
async def integrate_follows_the_golden(dut) -> None:
    from models.formats.number_format import FP32
    from models.kernel import kernel_vectors as kv
    from rtl.gen.kernel_graphs import GRAPHS

    seed = int(os.environ["TB_SEED"])
    rng, prng = np.random.default_rng(seed), random.Random(seed)
    fmt = FP32
    dt, damping, grav = 1 / 60, 0.99, (0.0, -9.8, 0.0)
    run = {"dt": dt, "damping": damping, "gx": grav[0], "gy": grav[1], "gz": grav[2]}
    await start(dut, {"init": 1, "active": 0, "nb": 0, "rd_rec": 0, "rd_bad": 0, "m_body_tready": 0,
                      **{k: int(fmt.encode(np.float64(v))) for k, v in run.items()}})
    twin = GRAPHS["pgs_integrate_pipe"]()
    for n in (0, 1, 37, 90):
        words, bad = bodies_table(rng, n)
        words = fmt.round(words)
        bits = fmt.encode(words).astype(np.int64)
        recs = [sum(int(b) << (32 * k) for k, b in enumerate(row)) for row in bits]
        dynamic = (words[:, 13] != 0) & ~bad
        x = np.concatenate([words[:, :13], np.tile([dt, damping, *grav], (n, 1))], axis=1)
        expect = words[:, :13].copy()
        with np.errstate(all="ignore"):
            if dynamic.any():
                expect[dynamic] = kv.integrate_golden(fmt, fmt.round(x[dynamic]))
            events = twin.count_events(fmt, fmt.round(x[dynamic])).as_dict() if dynamic.any() else {}
        out_bits = fmt.encode(expect).astype(np.int64)
        want = [sum(int(b) << (32 * k) for k, b in enumerate(row)) for row in out_bits]
        await cycle(dut, init=1, active=0, nb=n)
        got, beat, cur, done_at, prev_idx, ev = [], 0, 0, None, None, {"overflow": 0, "underflow": 0, "invalid": 0}
        for c in range(40 * n + 600):
            ready = int(prng.random() < (0.2 if (c // 50) % 3 == 0 else 0.9))
            rd = {} if prev_idx is None or prev_idx >= n else {"rd_rec": recs[prev_idx], "rd_bad": int(bad[prev_idx])}
            await cycle(dut, init=0, active=int(done_at is None), m_body_tready=ready, **rd)
            ev["overflow"] += val(dut.ev_overflow)
            ev["underflow"] += val(dut.ev_underflow)
            ev["invalid"] += val(dut.ev_invalid)
            if done_at is not None:
                assert not val(dut.m_body_tvalid), "a body-out beat after done"
                if c > done_at + 5:
                    break
                continue
            prev_idx = val(dut.rd_idx)
            assert prev_idx <= len(got) + FIFO_DEPTH + 1, f"cycle {c}: body {prev_idx} read with {len(got)} sent"
            if val(dut.m_body_tvalid) and ready:
                cur |= val(dut.m_body_tdata) << (BEAT * beat)
                last = val(dut.m_body_tlast)
                beat += 1
                if beat == 4:  # 13 words in 4 beats of 128 bits
                    assert last == int(len(got) == n - 1), f"body {len(got)}: TLAST {last}"
                    got.append(cur & ((1 << 13 * 32) - 1))
                    beat, cur = 0, 0
                else:
                    assert not last, f"body {len(got)}: TLAST on beat {beat - 1}"
            if val(dut.done):
                done_at = c
        assert done_at is not None and len(got) == n, f"{n} bodies: {len(got)} sent, done {done_at}"
        bad_rows = [k for k in range(n) if got[k] != want[k]]
        assert not bad_rows, f"{n} bodies: bodies {bad_rows[:8]} differ from the golden model"
        assert not dynamic.any() or ev == events, f"{n} bodies: events {ev}, twin {events}"
        assert n < 30 or ev["invalid"] > 0, "no body without spin (0/0, an invalid event) among many: the events unchecked"
        dut._log.info("%d bodies (%d dynamic, %d bad): done at cycle %s, events %s", n, int(dynamic.sum()),
                      int(bad.sum()), done_at, ev)


def test_seq_integrate() -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    rtl = REPO / "rtl"
    sources = [rtl / "pgs_fp_pkg.sv", rtl / "generated" / "pgs_stream_layout_pkg.sv", rtl / "pgs_seq_pkg.sv",
               *sorted((rtl / "fp").glob("*.sv")), rtl / "pgs_delay.sv", rtl / "generated" / "pgs_integrate_pipe.sv",
               rtl / "pgs_fifo.sv", rtl / "pgs_seq_integrate.sv"]
    results = run_cocotb("pgs_seq_integrate", sources, "test_seq_integrate",
                         parameters={"OUT_FIFO_DEPTH": FIFO_DEPTH}, seed=seed, extra_env={"TB_SEED": str(seed)})
    assert cocotb_results(results) == (1, 0)  # integrate_follows_the_golden ran and passed
