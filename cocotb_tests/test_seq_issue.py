"""cocotb bench of rtl/pgs_seq_issue.sv (the record checks, the take and the rejected-slot flags) against a model of
the rules in its header (rtl/README.md "Bad input").

Every cycle the bench offers a random record of LANES lanes: bodies from a small set with random dynamic and bad flags,
now and then a bad index, a non-finite word, an empty lane (the window kernel), a record cut short by TLAST, a fill slot
(the streaming kernel), a full impulse-out FIFO, a hazard (may_issue clear); the pass and slot step like the record
source's when the module says a slot is done, a step of four passes after the other. Checked every cycle against the model: the lanes that would issue, the
take, the issued and rejected lanes, the fill step, the slot step and the error pulses; and the rejected-slot flags: a
slot rejected in pass 0 (or later) stays rejected in every later pass. With the impulses in the records (the window
kernel) the flags are read as records enter the ring (w_asm_move, the bit back on w_rej_q the next cycle), and the
record's head bit (w_head_seen) decides. Configurations: the streaming kernel; the window kernel with two lanes; with four
lanes, the impulses in the records and eight body banks (a lane whose bank reads would exceed two ports is rejected).
``SEED=<n>`` reproduces a run.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import cocotb
import pytest

from tb.cycles import cycle, start, val

REPO = Path(__file__).resolve().parents[1]
IDX_W = 6  # MAX_BODIES = 64
SLOT_W = 7  # MAX_MANIFOLDS = 128
RECORDS = 6  # records per pass
PASSES = 4  # passes per step


def lanes_model(lanes: int, window: int, banks: int, rec: dict) -> tuple[list[int], list[int], list[int], list[int],
                                                                             list[int]]:
    """(go, rej, empty, static, collide) per lane for the record offered (the module's always_comb)."""
    go, rej_out, empty_out, static_out, collide_out = [], [], [], [], []

    def bank(b: int) -> int:
        return b % banks if banks > 1 else 0

    for l in range(lanes):
        a, b = rec["la"][l], rec["lb"][l]
        dyn_a, dyn_b = rec["dyn"][2 * l], rec["dyn"][2 * l + 1]
        empty = window > 0 and not rec["trunc"] and rec["empty"][l]
        rej_bad = not rec["index"][l] and (rec["bad"][2 * l] or rec["bad"][2 * l + 1])
        static = not rec["index"][l] and not rej_bad and not dyn_a and not dyn_b
        collide = any(go[k] and ((dyn_a and a in (rec["la"][k], rec["lb"][k]))
                                 or (dyn_b and b in (rec["la"][k], rec["lb"][k]))) for k in range(l))
        if banks > 0 and lanes > 1:
            in_a = 2 if bank(a) == bank(b) else 1
            in_b = in_a
            for k in range(l):
                if go[k]:
                    in_a += (bank(rec["la"][k]) == bank(a)) + (bank(rec["lb"][k]) == bank(a))
                    in_b += (bank(rec["la"][k]) == bank(b)) + (bank(rec["lb"][k]) == bank(b))
            collide = collide or in_a > 2 or in_b > 2
        rej = (rec["prev"][l] or rec["index"][l] or rej_bad or static or rec["nonfinite"][l] or rec["trunc"]
               or collide)
        go.append(int(not empty and not rej))
        rej_out.append(int(rej))
        empty_out.append(int(empty))
        static_out.append(int(static))
        collide_out.append(int(collide))
    return go, rej_out, empty_out, static_out, collide_out


def bits(values: list[int], width: int = 1) -> int:
    return sum(v << (width * k) for k, v in enumerate(values))


@cocotb.test()
async def issue_follows_the_model(dut) -> None:
    lanes, window, records_imp, banks = (int(os.environ[k]) for k in ("TB_LANES", "TB_WINDOW", "TB_IMP", "TB_BANKS"))
    rng = random.Random(int(os.environ["TB_SEED"]))
    ring_read = window > 0 and records_imp == 1  # the flags read as records enter the ring
    await start(dut, {"in_solve": 0, "rec_valid": 0, "rec_trunc": 0, "fill": 0, "imp_room": 1, "may_issue": 0,
                      "pass": 0, "slot": 0, "la": 0, "lb": 0, "l_empty_hdr": 0, "l_index": 0, "l_nonfinite": 0,
                      "dyn": 0, "bad": 0, "w_asm_move": 0, "w_asm_slot": 0, "w_head_seen": 0})
    flags = [[0] * RECORDS for _ in range(lanes)]  # the rejected-slot flags per lane, by record index
    pending_read: tuple[int, list[int]] | None = None  # a ring read of the cycle before: (slot, expected bits)
    pas, slot, fill = 0, 0, 0
    counts = {"take": 0, "reject": 0, "prev": 0, "collide": 0, "fill": 0}
    for c in range(6000):
        rec = {"la": [rng.randrange(10) for _ in range(lanes)], "lb": [rng.randrange(10) for _ in range(lanes)],
               "dyn": [int(rng.random() < 0.8) for _ in range(2 * lanes)],
               "bad": [int(rng.random() < 0.03) for _ in range(2 * lanes)],
               "index": [int(rng.random() < 0.03) for _ in range(lanes)],
               "nonfinite": [int(rng.random() < 0.03) for _ in range(lanes)],
               "empty": [int(window > 0 and rng.random() < 0.1) for _ in range(lanes)],
               "trunc": int(rng.random() < 0.01)}
        seen = [int(rng.random() < 0.5) for _ in range(lanes)] if ring_read else [0] * lanes
        valid = int(rng.random() < 0.85)
        imp_room = int(rng.random() < 0.95)
        may_issue = int(rng.random() < 0.7)
        move = int(ring_read and pas >= 1 and rng.random() < 0.3)  # (the flags are all written in pass 0)
        move_slot = rng.randrange(RECORDS)
        await cycle(dut, in_solve=1, rec_valid=valid, rec_trunc=rec["trunc"], fill=fill, imp_room=imp_room,
                    may_issue=may_issue, **{"pass": pas}, slot=slot, la=bits(rec["la"], IDX_W),
                    lb=bits(rec["lb"], IDX_W), l_empty_hdr=bits(rec["empty"]), l_index=bits(rec["index"]),
                    l_nonfinite=bits(rec["nonfinite"]), dyn=bits(rec["dyn"]), bad=bits(rec["bad"]),
                    w_asm_move=move, w_asm_slot=move_slot, w_head_seen=bits(seen))
        if pending_read is not None:
            assert val(dut.w_rej_q) == bits(pending_read[1]), f"cycle {c}: the ring read of slot {pending_read[0]}"
        pending_read = (move_slot, [flags[l][move_slot] for l in range(lanes)]) if move else None
        prev = seen if ring_read else [flags[l][slot] for l in range(lanes)]
        rec["prev"] = [int(pas != 0 and p) for p in prev]
        go, rej, empty, static, collide = lanes_model(lanes, window, banks, rec)
        take = int(valid and not fill and imp_room and (not any(go) or may_issue))
        fill_step = int(fill and imp_room)
        issue = [take and g for g in go]
        reject = [take and not e and r for e, r in zip(empty, rej)]
        checked = [take and not rec["trunc"] and not e for e in empty]
        want = {"l_go": bits(go), "take": take, "l_issue": bits(issue), "l_reject": bits(reject),
                "issue": int(any(issue)), "fill_step": fill_step, "slot_step": int(take or fill_step),
                "err_body_index": int(any(ck and (i or co) for ck, i, co in zip(checked, rec["index"], collide))),
                "err_nonfinite": int(any(ck and n for ck, n in zip(checked, rec["nonfinite"]))),
                "err_static_pair": int(any(ck and s for ck, s in zip(checked, static)))}
        got = {k: val(getattr(dut, k)) for k in want}
        assert got == want, f"cycle {c} (pass {pas}, slot {slot}): module {got}, model {want}"
        counts["take"] += take
        counts["reject"] += sum(reject)
        counts["prev"] += take and any(rec["prev"])
        counts["collide"] += take and any(collide)
        counts["fill"] += fill_step
        if take or fill_step:  # the flags' write, then the slot steps as the record source steps it
            for l in range(lanes):
                if pas == 0 or reject[l] or fill_step:
                    flags[l][slot] = int(reject[l] or fill_step) if not ring_read or window == 0 else reject[l]
            if slot == RECORDS - 1:  # a step of PASSES passes, then the next step from pass 0
                slot, pas, fill = 0, (pas + 1) % PASSES, 0
            else:
                slot += 1
                fill = int(window == 0 and (fill or (take and rng.random() < 0.02)))
    dut._log.info("takes %d, rejected lanes %d, takes with a slot rejected earlier %d, with a collision %d, "
                  "fill steps %d", *counts.values())
    assert counts["take"] > 1000 and counts["reject"] > 200 and counts["prev"] > 50, counts
    assert (counts["fill"] > 0) == (window == 0) and (counts["collide"] > 20) == (lanes > 1), counts


@pytest.mark.parametrize("lanes,window,imp,banks", [(1, 0, 0, 0), (2, 1024, 0, 0), (4, 1024, 1, 8)],
                         ids=["stream", "window-2lanes", "window-4lanes-records-banked"])
def test_seq_issue(lanes: int, window: int, imp: int, banks: int) -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    rtl = REPO / "rtl"
    results = run_cocotb("pgs_seq_issue", [rtl / "generated" / "pgs_stream_layout_pkg.sv", rtl / "pgs_seq_pkg.sv",
                                           rtl / "pgs_ring_ram.sv", rtl / "pgs_seq_issue.sv"], "test_seq_issue",
                         parameters={"MAX_BODIES": 1 << IDX_W, "MAX_MANIFOLDS": 1 << SLOT_W, "LANES": lanes,
                                     "WINDOW": window, "IMPULSES_IN_RECORDS": imp, "BODY_BANKS": banks}, seed=seed,
                         extra_env={"TB_SEED": str(seed), "TB_LANES": str(lanes), "TB_WINDOW": str(window),
                                    "TB_IMP": str(imp), "TB_BANKS": str(banks)})
    assert cocotb_results(results) == (1, 0)  # issue_follows_the_model ran and passed
