"""cocotb bench of rtl/pgs_seq_hazards.sv (the hazard CAM of the manifolds in flight and the issue rules) against a
model: a FIFO of the issued records' dynamic bodies.

Every cycle the bench offers a random record of LANES lanes (bodies from a small set, so that hazards are frequent,
in stretches with few dynamic bodies, so that the CAM fills;
random dynamic flags and issuing lanes, a random pass kind that changes in runs, a busy body bank now and then),
issues it when the module allows (and the bench wants to), and retires the oldest record in flight a fixed number of
cycles after its issue. Checked every cycle: `cand` (the body RAM's addresses: A and B of each lane), `hazard` (an
issuing lane's dynamic body is one of the dynamic bodies in flight, up to and including their retire cycle),
`may_issue` (no hazard, fewer than HAZARD_DEPTH in flight, no busy bank, and with two pipes on the streaming kernel the
kind issued last or nothing in flight) and `drained`. Configurations: the streaming kernel with two pipes (the drain
rule) and with the shared datapath, the window kernel with two lanes. ``SEED=<n>`` reproduces a run.
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
IDX_W = 6  # MAX_BODIES = 64
DEPTH = 8
LATENCY = 11  # issue to retire (more than DEPTH: the CAM fills)


@cocotb.test()
async def hazards_follow_the_model(dut) -> None:
    lanes, window, shared = (int(os.environ[k]) for k in ("TB_LANES", "TB_WINDOW", "TB_SHARED"))
    drains = not shared and window == 0
    rng = random.Random(int(os.environ["TB_SEED"]))
    await start(dut, {"init": 1, "la": 0, "lb": 0, "dyn": 0, "l_go": 0, "kind": 0, "issue": 0, "retire": 0,
                      "body_busy": 0})
    await cycle(dut, init=1)
    flight: deque[tuple[int, frozenset[int]]] = deque()  # (retire cycle, dynamic bodies) per issued record
    last_kind, kind = 0, 0
    seen = {"hazard": 0, "full": 0, "drain": 0, "issued": 0}
    for c in range(4000):
        if rng.random() < 0.08:
            kind ^= 1
        crowded = (c // 500) % 2 == 0  # stretches of frequent hazards, and of few (the CAM fills)
        bodies = [rng.randrange(12 if crowded else 1 << IDX_W) for _ in range(2 * lanes)]
        dyn = [int(rng.random() < (0.85 if crowded else 0.1)) for _ in range(2 * lanes)]
        go = [int(rng.random() < 0.9) for _ in range(lanes)]
        busy = int(rng.random() < 0.05)
        retire = int(bool(flight) and flight[0][0] == c)
        la = sum(bodies[2 * l] << (IDX_W * l) for l in range(lanes))
        lb = sum(bodies[2 * l + 1] << (IDX_W * l) for l in range(lanes))
        dyn_v = sum(d << k for k, d in enumerate(dyn))
        go_v = sum(g << l for l, g in enumerate(go))
        await cycle(dut, init=0, la=la, lb=lb, dyn=dyn_v, l_go=go_v, kind=kind, retire=retire, body_busy=busy,
                    issue=0)
        mine = {bodies[k] for k in range(2 * lanes) if dyn[k] and go[k // 2]}
        in_flight = set().union(*(b for _, b in flight)) if flight else set()
        hazard = bool(mine & in_flight)
        full = len(flight) >= DEPTH
        drain_block = drains and kind != last_kind and bool(flight)
        expect = not hazard and not full and not busy and not drain_block
        assert val(dut.cand) == sum(b << (IDX_W * k) for k, b in enumerate(bodies)), f"cycle {c}: cand"
        assert val(dut.hazard) == hazard, f"cycle {c}: hazard {val(dut.hazard)}, model {hazard} ({mine} vs {in_flight})"
        assert val(dut.may_issue) == expect, (f"cycle {c}: may_issue {val(dut.may_issue)}, model {expect} (hazard "
                                              f"{hazard}, full {full}, busy {busy}, drain {drain_block})")
        assert val(dut.drained) == (not flight), f"cycle {c}: drained {val(dut.drained)} with {len(flight)} in flight"
        seen["hazard"] += hazard
        seen["full"] += full
        seen["drain"] += drain_block
        issue = int(expect and go_v != 0 and rng.random() < 0.8)
        await respond(dut, issue=issue)  # the same cycle's issue
        if retire:
            flight.popleft()
        if issue:
            flight.append((c + LATENCY, frozenset(mine)))
            last_kind = kind
            seen["issued"] += 1
    dut._log.info("cycles with a hazard %d, CAM full %d, drain %d; issued %d", *seen.values())
    assert seen["hazard"] > 100 and seen["full"] > 10 and seen["issued"] > 500, seen
    assert (seen["drain"] > 10) == drains, seen


@pytest.mark.parametrize("lanes,window,shared", [(1, 0, 0), (1, 0, 1), (2, 1024, 1)],
                         ids=["stream-two-pipes", "stream-shared", "window-2lanes"])
def test_seq_hazards(lanes: int, window: int, shared: int) -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    rtl = REPO / "rtl"
    results = run_cocotb("pgs_seq_hazards", [rtl / "generated" / "pgs_stream_layout_pkg.sv", rtl / "pgs_seq_pkg.sv",
                                             rtl / "pgs_hazard_cam.sv", rtl / "pgs_seq_hazards.sv"], "test_seq_hazards",
                         parameters={"MAX_BODIES": 1 << IDX_W, "HAZARD_DEPTH": DEPTH, "LANES": lanes, "WINDOW": window,
                                     "SHARED_DATAPATH": shared}, seed=seed,
                         extra_env={"TB_SEED": str(seed), "TB_LANES": str(lanes), "TB_WINDOW": str(window),
                                    "TB_SHARED": str(shared)})
    assert cocotb_results(results) == (1, 0)  # hazards_follow_the_model ran and passed
