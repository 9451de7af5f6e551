"""cocotb bench of rtl/pgs_seq_load.sv, the sequencer's LOAD phase, against a model of what it must write.

Body-in records of random finite fp32 words (14 + IINV_W words, BODY_IN_W-bit beats) stream in with random idle cycles;
some records hold a non-finite word, a negative inverse mass or diagonal inverse inertia (bad bodies), a negative
zero or a negative off-diagonal word of the symmetric 3x3 (not bad). Scenarios: the right number of records with TLAST
on the last beat; an early TLAST (fewer records: the missing bodies are written as zero records, bad); a record cut
short by TLAST (written bad, the rest filled); a missing TLAST (extra records: discarded up to TLAST). Checked: every
body written exactly once, in index order, with the record's words (a whole record) and the bad flag the rules give;
the error pulses (code 0x02 once per TLAST error, the non-finite and negative-mass pulses once per such whole record);
`done` exactly once, after every beat of the stream was taken; nothing written before `active` or after `done`.
Built twice: the diagonal inverse inertia on 128-bit beats, the symmetric 3x3 on 256-bit beats.
``SEED=<n>`` reproduces a run.
"""

from __future__ import annotations

import os
import random
import struct
from dataclasses import dataclass, field
from pathlib import Path

import cocotb
import pytest

from tb.cycles import cycle, start, val

REPO = Path(__file__).resolve().parents[1]
W = 32
NONFINITE, NEG_MASS, NEG_ZERO, NEG_OFFDIAG = "nonfinite", "neg_mass", "neg_zero", "neg_offdiag"


def f32(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


@dataclass
class Scenario:
    name: str
    nb: int
    records: list[list[int]]  # the words of every record streamed (extra ones included)
    tlast_after: tuple[int, int]  # (record, beat) of the TLAST
    bad: list[bool] = field(default_factory=list)  # per body: written bad
    nonfinite: int = 0  # whole records with a non-finite word (error pulses)
    bad_mass: int = 0


def make_record(rng: random.Random, iinv_w: int, flaw: str | None) -> list[int]:
    words = [f32(rng.uniform(-10, 10)) for _ in range(13)] + [f32(rng.uniform(0.1, 3))]
    words += [f32(rng.uniform(0.1, 3)) for _ in range(min(iinv_w, 3))]
    words += [f32(rng.uniform(-1, 1)) for _ in range(iinv_w - 3)]  # off-diagonal words (IINV_W = 6)
    if flaw == NONFINITE:
        words[rng.randrange(len(words))] = rng.choice([0x7F800000, 0x7FC00000, 0x7F800001])  # +inf, NaNs
    elif flaw == NEG_MASS:
        k = rng.randrange(13, 14 + min(iinv_w, 3))
        words[k] |= 0x8000_0000
    elif flaw == NEG_ZERO:
        words[13] = 0x8000_0000  # -0 reads as zero: not negative
    elif flaw == NEG_OFFDIAG:
        words[17] = f32(-0.25)
    return words


def scenario(kind: str, rng: random.Random, iinv_w: int, nb: int, beats: int) -> Scenario:
    flaws: list[str | None] = [None] * nb
    for k in rng.sample(range(nb), 4):
        flaws[k] = rng.choice([NONFINITE, NEG_MASS, NEG_ZERO] + ([NEG_OFFDIAG] if iinv_w == 6 else []))
    extra = 3 if kind == "late" else 0
    records = [make_record(rng, iinv_w, f) for f in flaws + [None] * extra]
    streamed = nb - 3 if kind in ("early", "trunc") else nb + extra
    tlast = (streamed - 1, beats - 1) if kind != "trunc" else (streamed - 1, beats // 2)
    s = Scenario(kind, nb, records[:streamed], tlast)
    for k in range(nb):
        whole = k < streamed and not (kind == "trunc" and k == streamed - 1)
        flaw = flaws[k] if whole else None
        s.bad.append(not whole or flaw in (NONFINITE, NEG_MASS))
        s.nonfinite += flaw == NONFINITE
        s.bad_mass += flaw == NEG_MASS
    return s


def beats_of(words: list[int], beat_w: int, beats: int) -> list[int]:
    rec = sum(w << (W * k) for k, w in enumerate(words))
    return [(rec >> (beat_w * j)) & ((1 << beat_w) - 1) for j in range(beats)]


async def run_scenario(dut, s: Scenario, rng: random.Random, iinv_w: int, beat_w: int, beats: int) -> None:
    stream = [(b, (r, j) == s.tlast_after) for r, rec in enumerate(s.records)
              for j, b in enumerate(beats_of(rec, beat_w, beats)) if (r, j) <= s.tlast_after]
    await cycle(dut, init=1, active=0, nb=s.nb, s_body_tvalid=0)
    assert not val(dut.wr_en), "a body written while idle"
    nxt, writes, errs, done_at = 0, [], {"tlast": 0, "nonfinite": 0, "bad_mass": 0}, None
    valid = 0
    for c in range(20 * len(stream) + 200):
        if done_at is not None:  # the sequencer leaves LOAD with the done cycle
            await cycle(dut, init=0, active=0, s_body_tvalid=0)
            assert not val(dut.wr_en) and not val(dut.done), "a write or done after done"
            if c > done_at + 3:
                break
            continue
        valid = int(nxt < len(stream) and rng.random() < 0.75)
        beat, last = stream[nxt] if nxt < len(stream) else (0, 0)
        await cycle(dut, init=0, active=1, s_body_tvalid=valid, s_body_tdata=beat, s_body_tlast=int(last))
        if valid and val(dut.s_body_tready):
            nxt += 1
        if val(dut.wr_en):
            writes.append((val(dut.wr_idx), val(dut.wr_rec), val(dut.wr_bad)))
        errs["tlast"] += val(dut.err_tlast)
        errs["nonfinite"] += val(dut.err_nonfinite)
        errs["bad_mass"] += val(dut.err_bad_mass)
        if val(dut.done):
            done_at = c
    assert done_at is not None, f"{s.name}: LOAD never ended ({nxt} of {len(stream)} beats taken)"
    assert nxt == len(stream), f"{s.name}: done with {len(stream) - nxt} beats of the stream not taken"
    assert [w[0] for w in writes] == list(range(s.nb)), f"{s.name}: bodies written {[w[0] for w in writes]}"
    for k, (idx, rec, bad) in enumerate(writes):
        assert bad == s.bad[k], f"{s.name}: body {k} bad flag {bad}, expected {s.bad[k]}"
        if k >= len(s.records):
            assert rec == 0, f"{s.name}: body {k} (missing) must be a zero record"
        elif not (s.name == "trunc" and k == len(s.records) - 1):
            want = sum(w << (W * j) for j, w in enumerate(s.records[k]))
            assert rec == want, f"{s.name}: body {k} written with other words"
    assert errs == {"tlast": int(s.name != "normal"), "nonfinite": s.nonfinite, "bad_mass": s.bad_mass}, \
        f"{s.name}: error pulses {errs}, expected tlast {int(s.name != 'normal')}, nonfinite {s.nonfinite}, " \
        f"bad mass {s.bad_mass}"
    dut._log.info("%s: %d bodies, %d beats, done at cycle %d, bad %d", s.name, s.nb, len(stream), done_at, sum(s.bad))


@cocotb.test()
async def load_every_scenario(dut) -> None:
    iinv_w, beat_w = int(os.environ["TB_IINV_W"]), int(os.environ["TB_BODY_IN_W"])
    beats = -(-(14 + iinv_w) * W // beat_w)
    rng = random.Random(int(os.environ["TB_SEED"]))
    await start(dut, {"init": 1, "active": 0, "nb": 0, "s_body_tvalid": 0, "s_body_tdata": 0, "s_body_tlast": 0})
    for kind in ("normal", "early", "trunc", "late", "normal"):
        await run_scenario(dut, scenario(kind, rng, iinv_w, rng.randrange(8, 20), beats), rng, iinv_w, beat_w, beats)


@pytest.mark.parametrize("iinv_w,beat_w", [(3, 128), (6, 256)])
def test_seq_load(iinv_w: int, beat_w: int) -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    seed = test_seed()
    results = run_cocotb("pgs_seq_load", [REPO / "rtl" / "pgs_record_asm.sv", REPO / "rtl" / "pgs_seq_load.sv"],
                         "test_seq_load",
                         parameters={"IINV_W": iinv_w, "BODY_IN_W": beat_w}, seed=seed,
                         extra_env={"TB_SEED": str(seed), "TB_IINV_W": str(iinv_w), "TB_BODY_IN_W": str(beat_w)})
    assert cocotb_results(results) == (1, 0)  # load_every_scenario ran and passed
