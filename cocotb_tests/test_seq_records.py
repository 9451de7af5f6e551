"""cocotb bench of rtl/pgs_seq_records.sv in the streaming kernel's form (the records of every pass from s_cons) against
a model of what it must offer.

The bench streams the passes of a step (contact passes first, or interleaved) with random idle cycles: fp32 contact
records of two 512-bit beats and friction records of one, random headers (body indices, now and then out of range or
the same twice; the spin-damping and shock bits) and words (now and then a non-finite one). Some passes break the TLAST
rules: TLAST early (the missing slots are offered as fill), in the middle of a record (it is offered cut short, then
fill), or missing on the last record with extra beats after it (discarded up to TLAST). The bench takes the records
(and steps the fill slots) at random. Checked at every take: the pass, slot and kind, the cut-short flag, the bodies,
the header bits, the index and non-finite checks and the kind's words; the fill slots of each pass; `slot_last`; one
TLAST error pulse per broken pass; every beat taken. ``SEED=<n>`` reproduces a run.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import cocotb

from tb.cycles import cycle, respond, start, val

REPO = Path(__file__).resolve().parents[1]
W = 32
BEAT = 512
IDX_W = 6  # MAX_BODIES = 64
NB = 40
WORDS = {0: 23, 1: 14}  # contact, friction record words
BEATS = {0: 2, 1: 1}
NONFINITE = 0x7F800000


def pass_kinds(iters: int, interleaved: bool) -> list[int]:
    return [p % 2 for p in range(2 * iters)] if interleaved else [int(p >= iters) for p in range(2 * iters)]


def make_record(rng: random.Random, kind: int) -> dict:
    a, b = rng.randrange(NB), rng.randrange(NB)
    if rng.random() < 0.05:
        a = rng.randrange(NB, 1 << 20)  # out of range
    if rng.random() < 0.05:
        b = a  # the same body twice
    flags = rng.getrandbits(4)
    words = [rng.getrandbits(31) & 0x7F7FFFFF for _ in range(WORDS[kind])]  # finite
    if rng.random() < 0.05:
        words[rng.randrange(len(words))] = NONFINITE
    header = a | b << 32 | flags << 60
    bits = header | sum(w << (64 + W * j) for j, w in enumerate(words))
    return {"kind": kind, "a": a, "b": b, "flags": flags, "words": words,
            "index": int(a >= NB or b >= NB or a == b), "nonfinite": int(NONFINITE in words),
            "beats": [(bits >> (BEAT * j)) & ((1 << BEAT) - 1) for j in range(BEATS[kind])]}


async def offer(dut, rng: random.Random, want: tuple | None, step: int, nm: int) -> int:
    """Check what the module offers this cycle against the model's next offer ``want`` (None: none is due) and take it
    (a fill slot: step it) at random; returns 1 when taken."""
    if want is None:
        assert not val(dut.fill) and not val(dut.rec_valid), f"step {step}: an offer beyond the model's"
        return 0
    if val(dut.fill):
        assert want[0] == "fill", f"step {step}: fill offered, model {want[:3]}"
        assert (val(getattr(dut, "pass")), val(dut.slot)) == want[1:3], f"step {step}: fill slot"
        if rng.random() < 0.7:
            await respond(dut, slot_step=1)
            return 1
    elif val(dut.rec_valid) and rng.random() < 0.7:
        assert want[0] == "rec", f"step {step}: a record offered, model a fill at {want[1:3]}"
        _, p, s, r, cut = want
        got = {"pass": val(getattr(dut, "pass")), "slot": val(dut.slot), "kind": val(dut.rec_kind),
               "trunc": val(dut.rec_trunc), "slot_last": val(dut.slot_last)}
        assert got == {"pass": p, "slot": s, "kind": r["kind"], "trunc": int(cut), "slot_last": int(s == nm - 1)}, \
            f"step {step}: offered {got}, model pass {p} slot {s} kind {r['kind']} cut {cut}"
        if not cut:
            words = val(dut.l_words)
            got_words = [words >> (W * j) & 0xFFFFFFFF for j in range(WORDS[r["kind"]])]
            assert got_words == r["words"], (f"step {step} pass {p} slot {s} kind {r['kind']}: words differ at "
                                             f"{[j for j, (g, w) in enumerate(zip(got_words, r['words'])) if g != w]}")
            assert (val(dut.la), val(dut.lb)) == (r["a"] % (1 << IDX_W), r["b"] % (1 << IDX_W))
            fl = r["flags"]
            assert (val(dut.l_fa), val(dut.l_fb), val(dut.l_lin), val(dut.l_sd)) == (
                fl & 1, fl >> 1 & 1, fl >> 2 & 1, fl >> 3 & 1), f"step {step}: header bits"
            assert (val(dut.l_index), val(dut.l_nonfinite)) == (r["index"], r["nonfinite"]), \
                f"step {step} pass {p} slot {s}: checks"
        await respond(dut, take=1, slot_step=1)
        return 1
    return 0


@cocotb.test()
async def records_follow_the_model(dut) -> None:
    rng = random.Random(int(os.environ["TB_SEED"]))
    await start(dut, {"init": 1, "fetch_en": 0, "nb": NB, "nm": 0, "iters": 0, "passes": 0, "ilv": 0, "lag": 0,
                      "fetch": 0, "s_cons_tdata": 0, "s_cons_tvalid": 0, "s_cons_tlast": 0, "s1_kind": 0, "take": 0,
                      "slot_step": 0, "w_rej_q": 0})
    steps = 0
    for step in range(30):
        iters, interleaved, nm = rng.randrange(1, 4), rng.random() < 0.5, rng.randrange(3, 9)
        kinds = pass_kinds(iters, interleaved)
        beats: list[tuple[int, int]] = []  # the stream: (tdata, tlast)
        offers: list[tuple] = []  # expected at each take, in order: ("rec", pass, slot, record, trunc) / ("fill", ...)
        broken = 0
        for p, kind in enumerate(kinds):
            recs = [make_record(rng, kind) for _ in range(nm)]
            rule = rng.choice(["ok", "ok", "early", "cut", "missing"])
            if rule == "cut" and kind == 1:
                rule = "early"  # a one-beat record cannot be cut short
            end = rng.randrange(nm - 1) if rule in ("early", "cut") else nm - 1  # the record with TLAST
            for s, r in enumerate(recs[:end + 1]):
                cut = rule == "cut" and s == end
                for j, bt in enumerate(r["beats"][:1] if cut else r["beats"]):
                    beats.append((bt, int(s == end and (cut or j == len(r["beats"]) - 1) and rule != "missing")))
                offers.append(("rec", p, s, r, cut))
            offers += [("fill", p, s) for s in range(end + 1, nm)]
            if rule == "missing":  # extra beats, the last with TLAST
                extra = rng.randrange(1, 4)
                beats += [(rng.getrandbits(BEAT), int(k == extra - 1)) for k in range(extra)]
            broken += rule != "ok"
            dut._log.info("step %d pass %d kind %d: %s, TLAST on record %d", step, p, kind, rule, end)
        await cycle(dut, init=1, fetch_en=0, take=0, slot_step=0, s_cons_tvalid=0)
        await cycle(dut, init=0, fetch_en=1, nm=nm, iters=iters, passes=2 * iters, ilv=int(interleaved))
        nxt, k, errs = 0, 0, 0  # beats taken, offers taken, TLAST error pulses
        for c in range(40 * len(beats) + 500):
            valid = int(nxt < len(beats) and rng.random() < 0.8)
            data, last = beats[nxt] if nxt < len(beats) else (0, 0)
            await cycle(dut, s_cons_tvalid=valid, s_cons_tdata=data, s_cons_tlast=last, take=0, slot_step=0)
            k += await offer(dut, rng, offers[k] if k < len(offers) else None, step, nm)
            if valid and val(dut.s_cons_tready):  # (after the take: it can free the assembler this cycle)
                nxt += 1
            errs += val(dut.err_tlast)
            if k == len(offers) and nxt == len(beats):
                break
        assert k == len(offers), f"step {step}: {k} of {len(offers)} offers seen"
        assert nxt == len(beats), f"step {step}: {len(beats) - nxt} beats not taken"
        assert errs == broken, f"step {step}: {errs} TLAST error pulses, {broken} passes broke the rules"
        steps += len(offers)
        dut._log.info("step %d: %d passes of %d records, %d broken, %d beats", step, len(kinds), nm, broken, len(beats))
    assert steps > 100


def test_seq_records() -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    rtl = REPO / "rtl"
    results = run_cocotb("pgs_seq_records", [rtl / "generated" / "pgs_stream_layout_pkg.sv", rtl / "pgs_seq_pkg.sv",
                                             rtl / "pgs_record_asm.sv", rtl / "pgs_ring_ram.sv", rtl / "pgs_window.sv",
                                             rtl / "pgs_seq_records.sv"], "test_seq_records",
                         parameters={"MAX_BODIES": 1 << IDX_W}, seed=seed, extra_env={"TB_SEED": str(seed)})
    assert cocotb_results(results) == (1, 0)  # records_follow_the_model ran and passed
