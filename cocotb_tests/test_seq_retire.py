"""cocotb bench of rtl/pgs_seq_retire.sv (the trace port and the impulse-out stream) against a model of both.

The bench plays the sequencer: while the module has room (imp_room) it steps slots at random, each issued (some of
its lanes retire a fixed latency later with random impulse and velocity words) or rejected, each of a pass that writes
its impulses out (w_lastg) or not, TLAST on every sixth; m_imp_tready drops at random, in stretches. Checked: every cycle, the trace
port's valid bits and records (impulses, velocities, slot, iteration, kind at their bit positions); the impulse-out
stream, record by record: one per slot of a pass that writes out, in slot order, zeros for a rejected slot and for a
lane that did not retire, TLAST on the pass's last slot; imp_room falls when the order FIFO is full (a small one here)
and imp_idle once every record has left. With IMPULSES_IN_RECORDS = 0 the stream stays idle and the room open.
``SEED=<n>`` reproduces a run.
"""

from __future__ import annotations

import os
import random
from collections import deque
from pathlib import Path

import cocotb
import pytest

from tb.cycles import cycle, respond, start, val

REPO = Path(__file__).resolve().parents[1]
W = 32
SLOT_W = 10  # MAX_MANIFOLDS = 1024
ITER_W = 16
TRACE_W = 16 * W + 64
LATENCY = 7
FIFO_DEPTH = 8


def pack(values: list[int], width: int) -> int:
    return sum(v << (width * k) for k, v in enumerate(values))


@cocotb.test()
async def retire_follows_the_model(dut) -> None:
    lanes, records = int(os.environ["TB_LANES"]), int(os.environ["TB_IMP"])
    rng = random.Random(int(os.environ["TB_SEED"]))
    await start(dut, {"slot_step": 0, "slot_last": 0, "w_lastg": 0, "issue": 0, "l_retire": 0, "l_kind": 0,
                      "l_lastg": 0, "l_imp": 0, "l_vel": 0, "l_slot": 0, "l_iter": 0, "m_imp_tready": 0})
    retires: dict[int, dict] = {}  # cycle -> the retire's lanes
    order: deque[tuple[bool, int]] = deque()  # (rejected, last) of every slot of a pass that writes out
    data: deque[int] = deque()  # the retired impulse words of those slots, in order
    got, want, full_seen, steps = [], [], 0, 0
    for c in range(3000):
        r = retires.pop(c, None)
        inputs = {"l_retire": 0, "l_kind": 0, "l_lastg": 0, "l_imp": 0, "l_vel": 0, "l_slot": 0, "l_iter": 0}
        if r is not None:
            inputs = {"l_retire": pack(r["mask"], 1), "l_kind": pack(r["kind"], 1),
                      "l_lastg": pack([r["lastg"]] * lanes, 1), "l_imp": pack(r["imp"], 4 * W),
                      "l_vel": pack(r["vel"], 12 * W), "l_slot": pack(r["slot"], SLOT_W),
                      "l_iter": pack(r["iter"], ITER_W)}
            if r["lastg"]:
                data.append(pack([i if m else 0 for i, m in zip(r["imp"], r["mask"])], 4 * W))
        # stretches of a slow reader (the FIFO fills), then a fast one; every record taken at the end
        ready = int(rng.random() < (0.1 if (c // 100) % 3 == 0 else 0.8)) if c < 2800 else 1
        await cycle(dut, slot_step=0, m_imp_tready=ready, **inputs)
        # the trace of this cycle's retire
        assert val(dut.trace_valid) == inputs["l_retire"], f"cycle {c}: trace_valid"
        if r is not None:
            trace = val(dut.trace_data)
            for l in range(lanes):
                rec = trace >> (l * TRACE_W)
                want_rec = (r["imp"][l] | r["vel"][l] << (4 * W) | r["slot"][l] << (16 * W)
                            | r["iter"][l] << (16 * W + 32) | r["kind"][l] << (16 * W + 48))
                assert rec & ((1 << TRACE_W) - 1) == want_rec, f"cycle {c}: lane {l}'s trace record"
        # the impulse-out stream (the order FIFO holds the entries pushed before this cycle's edge)
        room = val(dut.imp_room)
        assert room == (not records or len(order) < FIFO_DEPTH), f"cycle {c}: imp_room with {len(order)} queued"
        full_seen += not room
        if val(dut.m_imp_tvalid) and ready:
            got.append((val(dut.m_imp_tdata), val(dut.m_imp_tlast)))
            rejected, last = order.popleft()
            want.append((0 if rejected else data.popleft(), int(last)))
        if room and c < 2700 and rng.random() < 0.6:
            lastg = int(not records or rng.random() < 0.7)
            issue = int(rng.random() < 0.8)
            last = int(steps % 6 == 5)
            steps += 1
            await respond(dut, slot_step=1, slot_last=last, w_lastg=lastg, issue=issue)
            if lastg and records:
                order.append((not issue, last))
            if issue:
                mask = [int(rng.random() < 0.8) for _ in range(lanes)]
                mask[rng.randrange(lanes)] = 1
                retires[c + LATENCY] = {
                    "mask": mask, "lastg": lastg, "kind": [rng.randrange(2) for _ in range(lanes)],
                    "imp": [rng.getrandbits(4 * W) for _ in range(lanes)],
                    "vel": [rng.getrandbits(12 * W) for _ in range(lanes)],
                    "slot": [rng.getrandbits(SLOT_W) for _ in range(lanes)],
                    "iter": [rng.getrandbits(ITER_W) for _ in range(lanes)]}
    assert got == want, f"impulse-out records differ from the model (first {next((k for k, (g, w) in enumerate(zip(got, want)) if g != w), len(got))})"
    assert val(dut.imp_idle) and not order, "records left in the impulse-out stream"
    dut._log.info("%d slot steps, %d impulse-out records, %d cycles with the order FIFO full", steps, len(got),
                  full_seen)
    assert steps > 800 and (len(got) > 500 and full_seen > 20) == bool(records)


@pytest.mark.parametrize("lanes,imp", [(1, 1), (4, 1), (2, 0)], ids=["records", "records-4lanes", "onchip-2lanes"])
def test_seq_retire(lanes: int, imp: int) -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    rtl = REPO / "rtl"
    results = run_cocotb("pgs_seq_retire", [rtl / "generated" / "pgs_stream_layout_pkg.sv", rtl / "pgs_seq_pkg.sv",
                                            rtl / "pgs_fifo.sv", rtl / "pgs_seq_retire.sv"], "test_seq_retire",
                         parameters={"MAX_MANIFOLDS": 1 << SLOT_W, "LANES": lanes, "IMPULSES_IN_RECORDS": imp,
                                     "IMP_FIFO_DEPTH": FIFO_DEPTH}, seed=seed,
                         extra_env={"TB_SEED": str(seed), "TB_LANES": str(lanes), "TB_IMP": str(imp)})
    assert cocotb_results(results) == (1, 0)  # retire_follows_the_model ran and passed
