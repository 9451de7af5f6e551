"""The window kernel's cycle model (models/timing/window_cycle_model.py) on a hand-derived timeline and on the rules
it must keep on random steps (with the impulses on chip, and in the records with and without banked body velocities);
the RTL comparisons (every retire cycle) are in cocotb_tests/test_kernel_window.py (test_window_cycles_match_model)
and cocotb_tests/test_kernel_window_records.py (test_cycles_match_model)."""

from __future__ import annotations

import dataclasses
from array import array

import numpy as np
import pytest

from models.timing import cycle_model as cm
from models.timing import kernel_shape as ks
from models import scenes
from models.timing import window_cycle_model as wm
from models.kernel.body_banks import busy as bank_busy, over_ports
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32
from models.kernel.record_window import WindowPlan, fits, lane_slots
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.order.manifold_schedule import band_width
from models.tests.test_record_window import _chain
from models.timing import cycle_model
from models.timing import prediction
from sim.compare import retire_cycles

SHAPE = ks.KernelShape.of(FP32, 512)
RECORDS = ks.KernelShape.of(FP32, 512, impulses_in_records=True)  # the window kernel with the impulses in the records
IDEAL, ZCU102 = ks.DmaTiming.of(get_preset("ideal")), ks.DmaTiming.of(get_preset("zcu102"))
C_LAT = SHAPE.contact_latency


def one_manifold() -> tuple[ks.StepShape, WindowPlan]:
    """Ground (static) and one cube, one manifold, one iteration (a contact and a friction pass), one lane."""
    step = ks.StepShape.of(FP32, np.array([0.0, 1.0]), np.array([0]), np.array([1]), SolverParams(1))
    return step, WindowPlan(4, 2, 1, 2, 1, 1, np.array([0]))


def test_one_manifold_ideal_timeline() -> None:
    """By hand from the RTL: body-in beats 0..9, SOLVE from 12; the window record's 3 beats at 0, 1, 2, in the ring
    from 5 (accumulator, record register, ring write); passes 0 and 1 start at cycles 0 and 1. Pass 0 takes at 12
    (SOLVE), retires at 12 + 1 + 179; pass 1 is a candidate from 13 (pass 0 done) but the cube is in flight: it
    stalls until one cycle after that retire (193) and retires 180 cycles later, although friction (the friction
    pipe is delayed to the contact pipe's latency). INTEG from 375, the bodies' 4 body-out beats end at 570, DONE
    571."""
    p = wm.predict_window(SHAPE, IDEAL, *one_manifold())
    assert p.issue.tolist() == [12, 193] and p.retire.tolist() == [192, 373] and p.ready.tolist() == [5, 5]
    assert p.eligible.tolist() == [5, 13] and p.kind.tolist() == [0, 1] and p.took.tolist() == [[12], [193]]
    assert p.cause.tolist() == [prediction.SOLVE_START, prediction.HAZARD] and p.blocker.tolist() == [-1, 0]
    assert p.phases == {"LOAD": 0, "SOLVE": 12, "DRAIN": 194, "INTEG": 375, "DONE": 571} and p.cycles == 573
    assert (p.stalls, p.bubbles) == (180, 0) and p.stall_cycles_by_cause()["hazard"] == 180
    assert "waited 180 cycles for the hazard on the record's body 1 with retire #0" in p.explain(1)
    assert "waited for SOLVE" in p.explain(0)


def test_empty_steps() -> None:
    step, plan = one_manifold()
    none = dataclasses.replace(step, num_bodies=0, body_a=np.zeros(0, np.int64), body_b=np.zeros(0, np.int64),
                               dynamic=np.zeros(0, bool))
    assert wm.predict_window(SHAPE, IDEAL, none, dataclasses.replace(plan, slots=np.zeros(0, np.int64))).cycles == 3
    no_pass = wm.predict_window(SHAPE, IDEAL, dataclasses.replace(step, passes=()), plan)
    assert no_pass.manifold_passes == 0 and no_pass.phases["INTEG"] == no_pass.solve_start == 12


# --- random steps ---------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Case:
    seed: int
    lanes: int = 2
    depth: int = 64
    fetch_passes: int | None = None  # None: the most that fit
    lag: int | None = None  # None: the band width
    interleaved: bool = False
    naive_lanes: bool = False  # consecutive manifolds in a record (colliding lanes are rejected)
    bad: int = 0  # manifolds with a body index out of range or the same body twice
    dma: str = "zcu102"
    records: bool = False  # the impulses in the records (the fetches each serve passes of one kind)
    banks: int = 0  # banked body velocities
    imp_fifo: int = ks.IMPULSE_FIFO_DEPTH  # the impulse-out FIFO's entries

    @property
    def shape(self) -> ks.KernelShape:
        """The build the case runs on."""
        if not self.records:
            return SHAPE
        return dataclasses.replace(RECORDS, body_banks=self.banks, impulse_fifo_depth=self.imp_fifo)


def random_step(case: Case, m: int = 240, nb: int = 70) -> tuple[ks.StepShape, WindowPlan]:
    """``m`` manifolds over ``nb`` bodies (some static), each joining nearby bodies, in a local order."""
    rng = np.random.default_rng(case.seed)
    cons, _ = _chain(m)
    cons.body_a[:] = rng.integers(0, nb - 8, m)
    cons.body_b[:] = cons.body_a + rng.integers(1, 8, m)
    dyn = rng.random(nb) > 0.15
    order = np.argsort(np.minimum(cons.body_a, cons.body_b) + 4 * rng.random(m), kind="stable")
    lanes = case.lanes
    slots = (np.concatenate([order, np.full(-m % lanes, -1)]) if case.naive_lanes
             else lane_slots(order, cons, dyn, lanes, case.banks))
    band = band_width(slots, cons, dyn, lanes)
    lag = case.lag or max(1, band)
    fp = case.fetch_passes or max(f for f in range(1, 9) if fits(case.depth, 8, lag, f))
    real = np.maximum(slots, 0)
    a = np.where(slots >= 0, cons.body_a[real], -1)
    b = np.where(slots >= 0, cons.body_b[real], -1)
    broken = rng.choice(np.flatnonzero(slots >= 0), case.bad, replace=False)
    a[broken[::2]] = nb + 3  # out of range
    b[broken[1::2]] = a[broken[1::2]]  # the same body twice
    step = ks.StepShape.of(FP32, dyn.astype(float), a, b, SolverParams(2, interleaved=case.interleaved))
    return step, WindowPlan(case.depth, 8, lag, fp, band, lanes, slots)


# the impulses in the records: 2 iterations, so 1 or 2 passes per fetch (1 interleaved)
RECORD_CASES = [Case(21, lanes=1, depth=1024, fetch_passes=2, records=True, banks=2),
                Case(22, lanes=1, depth=1024, fetch_passes=1, records=True, banks=2, bad=10),
                Case(23, lanes=1, fetch_passes=1, records=True, banks=2, interleaved=True, dma="ideal"),
                Case(24, lanes=2, depth=1024, fetch_passes=2, records=True),
                Case(25, lanes=4, fetch_passes=1, records=True, lag=2, depth=16),
                Case(26, lanes=1, depth=1024, fetch_passes=2, records=True, imp_fifo=2),
                Case(27, lanes=1, fetch_passes=1, records=True, banks=2, imp_fifo=3, bad=6),
                Case(28, lanes=2, fetch_passes=1, records=True, imp_fifo=2, naive_lanes=True),
                Case(29, lanes=2, depth=1024, fetch_passes=2, records=True, banks=4),
                Case(30, lanes=2, fetch_passes=1, records=True, banks=2, naive_lanes=True)]
CASES = [Case(1), Case(2, lanes=1), Case(3, lanes=4), Case(4, fetch_passes=1), Case(5, fetch_passes=3),
         Case(6, lag=1, fetch_passes=8), Case(7, interleaved=True, fetch_passes=2), Case(8, naive_lanes=True),
         Case(9, bad=12), Case(10, dma="ideal"), Case(11, depth=16, lag=2, fetch_passes=2),
         Case(12, depth=1024, lanes=1, dma="ideal"), Case(13, lanes=2, depth=32, fetch_passes=8, lag=4),
         *RECORD_CASES]


def predict_case(case: Case, jumps: bool = True) -> tuple[wm.WindowPrediction, ks.StepShape, WindowPlan]:
    step, plan = random_step(case)
    dma = ks.DmaTiming.of(get_preset(case.dma))
    return wm.predict_window(case.shape, dma, step, plan, jumps), step, plan


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c.seed}")
def test_rules_hold(case: Case) -> None:
    """What every prediction must keep: retire = issue + 1 + C_LAT; one take a cycle, the lanes of one issue
    together in lane order; no issue while a dynamic body of it is in flight (issue .. retire inclusive); each pass's
    slots in order and trailing the pass before by ``lag``; the counts and SOLVE's cycles add up."""
    p, step, plan = predict_case(case)
    passes, nrec = len(step.passes), len(plan.slots) // plan.lanes
    assert np.array_equal(p.retire, p.issue + 1 + C_LAT)
    took = p.took
    assert took.shape == (passes, nrec) and np.unique(took).size == took.size  # one take a cycle
    assert np.all(np.diff(took, axis=1) > 0)  # each pass in slot order
    for j in range(1, passes):  # pass j's record r after pass j - 1 stepped min(r + lag, nrec) records
        ahead = took[j - 1, np.minimum(np.arange(nrec) + plan.lag, nrec) - 1]
        assert np.all(took[j] > ahead)
    # the issued lanes: each take's lanes together, in lane order, at that pass's take of that record
    rec = p.slot // plan.lanes
    assert np.array_equal(took[p.pass_index, rec], p.issue)
    same = p.issue[1:] == p.issue[:-1]
    assert np.all(p.slot[1:][same] > p.slot[:-1][same]) and np.all(np.diff(p.issue) >= 0)
    # hazards: a body's next issue only after the retire of the one before
    for body in np.unique(np.concatenate([p.body_a, p.body_b])):
        if body < 0:
            continue
        iss = np.sort(p.issue[(p.body_a == body) | (p.body_b == body)])
        rets = iss + 1 + C_LAT
        assert np.all(iss[1:] > rets[:-1]), f"body {body} issued while in flight"
    assert np.all(p.issue >= p.eligible) and np.all(p.eligible >= p.ready)
    if case.banks and plan.lanes > 1:  # the issuing lanes of a take read each bank at most twice (its ports)
        for t in np.unique(p.issue):
            at = np.flatnonzero(p.issue == t)
            reads = tuple(int(x) for s in p.slot[at] for x in (step.body_a[s], step.body_b[s]))
            assert not over_ports(case.banks, reads), f"take at {t} reads {reads}"
    empty = int(np.count_nonzero(plan.slots < 0))
    assert p.manifold_passes + p.rejected + empty * passes == len(plan.slots) * passes
    assert p.stalls + p.bubbles + took.size == p.solve_end - p.solve_start + 1 == took.max() - p.solve_start + 1
    assert sum(p.stall_cycles_by_cause().values()) == p.stalls


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c.seed}")
def test_stretch_jumps_change_nothing(case: Case) -> None:
    """The model jumps over stretches without a take (the skip marks' rotation in closed form, the fetch ahead of
    time); stepping every cycle gives the same prediction."""
    fast, _, _ = predict_case(case)
    slow, _, _ = predict_case(case, jumps=False)
    for name in ("issue", "slot", "kind", "iteration", "ready", "eligible", "cause", "blocker", "took", "started",
                 "first_beat", "impulse_out", "raw_wait"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    assert (fast.cycles, fast.stalls, fast.bubbles, fast.rejected, fast.stall_causes) == \
        (slow.cycles, slow.stalls, slow.bubbles, slow.rejected, slow.stall_causes)


def _offers(skip: int, elig: list[int], ctx_mask: int, n: int) -> list[tuple[int, int]]:
    """The window's offer and skip marks cycle by cycle without a take (pgs_window: the oldest eligible context not
    skipped, else the oldest; an offer not taken marks it, or clears the marks when none was fresh)."""
    out = []
    for _ in range(n):
        fresh = [j for j in elig if not skip >> (j & ctx_mask) & 1]
        out.append((fresh[0] if fresh else elig[0], skip))
        skip = skip | 1 << (fresh[0] & ctx_mask) if fresh else 0
    out.append((-1, skip))
    return out


def test_skip_rotation_in_closed_form() -> None:
    rng = np.random.default_rng(7)
    for _ in range(400):
        m = int(rng.integers(1, 6))
        first = int(rng.integers(0, 20))
        elig = sorted(rng.choice(np.arange(first, first + 8), m, replace=False).tolist())
        skip = int(rng.integers(0, 256))
        need = rng.integers(-3, 25, m).tolist()
        seq = _offers(skip, elig, 7, 40)
        for i in (1, 2, 5, 17, 39):
            assert wm._skip_after(skip, elig, 7, i) == seq[i][1]
        want = next((i for i in range(1, 40) if i >= need[elig.index(seq[i][0])]), 40)
        assert wm._pick_after(skip, elig, 7, need, 40) == want


def test_rejected_and_colliding_lanes() -> None:
    """Slots with a bad index (or between two static bodies) are rejected in every pass; with lanes paired naively, a
    lane sharing a dynamic body with an earlier issuing lane of its record is rejected too, in every pass."""
    p, step, plan = predict_case(Case(9, bad=12))
    bad = int(np.count_nonzero(step.rejected_slots() & (plan.slots >= 0)))
    assert bad >= 12 and p.rejected == bad * len(step.passes)
    q, step, plan = predict_case(Case(8, naive_lanes=True))
    assert q.rejected > 0 and q.rejected % len(step.passes) == 0
    assert q.manifold_passes + q.rejected == int(np.count_nonzero(plan.slots >= 0)) * len(step.passes)


def _last_passes(p: wm.WindowPrediction) -> list[int]:
    """The last pass of each fetch."""
    assert p.plan is not None
    passes, fp = len(p.started), p.plan.fetch_passes
    return [min(f + fp, passes) - 1 for f in range(0, passes, fp)]


def test_ring_room_and_the_last_pass_start_rule() -> None:
    """A ring of 16 records: one fetch of 8 passes waits for room (the last pass frees in slot order), and so do
    several fetches in the ring at once, whose last passes start only once every pass of the earlier fetches is
    done (jlo, one cycle after a pass's last take, then its register): the frees stay in ring order and no record is
    written over one a pass still needs. The check itself counts a free that comes after the write over it."""
    one, _, _ = predict_case(Case(11, depth=16, lag=2, fetch_passes=8))
    assert one.room_wait.max() > 0 and one.overwritten == 0
    for case in (Case(11, depth=16, lag=2, fetch_passes=2), Case(25, lanes=4, fetch_passes=1, records=True, lag=2,
                                                                  depth=16)):
        several, _, _ = predict_case(case)
        assert several.room_wait.max() > 0 and several.overwritten == 0
        assert "ring records overwritten" not in " ".join(several.summary())
        lasts, fp, binds = _last_passes(several), case.fetch_passes or 0, 0
        for f, last in enumerate(lasts[1:], 1):
            done = int(several.took[:f * fp, -1].max())  # the last take of the earlier fetches' passes
            assert several.started[last] >= done + 2
            binds += int(several.started[last] == done + 2)
        assert binds > 0  # the rule holds the start back (the contexts alone would allow it earlier)
    fetch = wm._Fetch(None, 1, 4, 2, 4, 0, 1)
    fetch.last_beat = array("q", [0, 1, 2, 3, 10, 11, 12, 13])  # records 4.. written at 12, 13, 14, 15
    assert fetch.overwritten(np.array([5, 20, 6, 16, 30, 31, 32, 33])) == 2  # records 1 and 3 freed after


def test_impulses_out_and_the_read_after_write_rule() -> None:
    """The impulses in the records: the last pass of each fetch sends one impulse-out record per window record, in
    order, the cycle after its retire (a record without an issuing lane: after its take) at the earliest; the
    harness offers record k of fetch f > 0 no earlier than the turnaround after fetch f - 1's record k left (and the
    rule holds some records back); DONE after the last one; the DDR's rate is the read share."""
    turnaround, binds = get_preset("zcu102").impulse_turnaround_cycles, 0
    for case in RECORD_CASES:
        p, step, plan = predict_case(case)
        nrec = len(plan.slots) // plan.lanes
        lasts = _last_passes(p)
        out = p.impulse_out
        assert out.shape == p.first_beat.shape == (len(lasts), nrec)
        assert np.all(np.diff(out.ravel()) > 0) and np.all(out > p.took[lasts])
        issued = np.isin(p.pass_index, lasts)
        fetch = p.pass_index[issued] // plan.fetch_passes
        assert np.all(out[fetch, p.slot[issued] // plan.lanes] > p.retire[issued])
        if case.dma == "zcu102":
            gap = p.first_beat[1:] - (out[:-1] + turnaround)
            assert gap.min() >= 0
            binds += int(np.count_nonzero(gap == 0))
            assert (p.raw_wait.max() > 0) == (case.depth >= nrec)  # a smaller ring holds the next fetch back longer
        assert p.phases["DONE"] >= out.max() + 2
    assert binds > 0
    wide = wm.predict_window(SHAPE, ZCU102, *random_step(Case(24, lanes=2, fetch_passes=2)))
    assert wide.impulse_out.size == 0 and wide.raw_wait.max() == 0
    job = _records_job(2)
    share = job.ddr_read_share(512)
    assert 0 < share < 1 and cycle_model.job_timing(job, get_preset("zcu102"), False).rate == \
        ks.DmaTiming.of(get_preset("zcu102"), read_share=share).rate


def test_no_take_while_the_impulse_out_fifo_is_full() -> None:
    """The order FIFO (an entry from the take of a fetch's last pass to its record's handshake) holds every take of
    every pass while full: with 2 or 3 entries it fills (the records leave after the pipe's latency) and holds
    takes back; with the kernel's 256 it never fills (a record leaves at most C_LAT + 2 cycles after its take)."""
    for case in RECORD_CASES:
        p, _, _ = predict_case(case)
        lasts = _last_passes(p)
        pushed = np.sort(p.took[lasts].ravel())
        popped = np.sort(p.impulse_out.ravel())
        takes = p.took.ravel()
        held = np.searchsorted(pushed, takes) - np.searchsorted(popped, takes)  # entries before the take's cycle
        assert held.max() <= case.imp_fifo - 1
        full = p.stall_cycles_by_cause()["impulse-out FIFO full"]
        if case.imp_fifo <= 3:
            assert held.max() == case.imp_fifo - 1 and full > 0 and np.any(p.cause == prediction.IMP_FULL)
            assert "impulse-out FIFO full (" in p.explain(int(np.flatnonzero(p.cause == prediction.IMP_FULL)[0]))
        else:
            assert full == 0 and held.max() <= C_LAT + 2


def test_banked_body_velocities() -> None:
    """Banked body velocities (one lane and two): no record issues in a cycle where the writes of the manifolds
    retiring then and the reads of its issuing lanes' bodies A and B need a third access to a bank; the rule holds
    takes back (stalls, BANK_BUSY causes) that the multiport memory would have issued. A record without an issuing
    lane is consumed whatever the banks."""
    for case in (c for c in RECORD_CASES if c.banks):
        p, step, plan = predict_case(case)
        writes: dict[int, tuple[int, ...]] = {}
        reads: dict[int, tuple[int, ...]] = {}
        for k in range(p.manifold_passes):
            s, r, t = int(p.slot[k]), int(p.retire[k]), int(p.issue[k])
            writes[r] = writes.get(r, ()) + tuple(int(b) for b in (p.body_a[k], p.body_b[k]) if b >= 0)
            reads[t] = reads.get(t, ()) + (int(step.body_a[s]), int(step.body_b[s]))
        for t, read in reads.items():
            assert not bank_busy(case.banks, read, writes.get(t, ())), f"a take at {t} with a bank busy"
        if case.lanes > 1:  # a lane over a bank's ports is rejected (naive lanes: a plan that makes some)
            assert case.naive_lanes <= (p.rejected > predict_case(dataclasses.replace(case, banks=0))[0].rejected)
            continue
        busy = p.stall_cycles_by_cause()["body bank busy with a retire write"]
        assert busy > 0 and np.any(p.cause == prediction.BANK_BUSY)
        k = int(np.flatnonzero(p.cause == prediction.BANK_BUSY)[0])
        assert "a body-velocity bank busy with the writes of retire #" in p.explain(k)
        multiport, _, _ = predict_case(dataclasses.replace(case, banks=0))
        hit = [any(bank_busy(2, (int(step.body_a[s]), int(step.body_b[s])),
                             tuple(int(b) for b in (multiport.body_a[x], multiport.body_b[x]) if b >= 0))
                   for x in np.flatnonzero(multiport.retire == t)) for s, t in zip(multiport.slot, multiport.issue)]
        assert any(hit) and "body bank busy with a retire write" not in multiport.stall_cycles_by_cause()
    rejected, _, _ = predict_case(RECORD_CASES[1])
    assert rejected.rejected > 0


def _records_job(lanes: int) -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return KernelJob.from_frame(frame, FP32, SolverParams(4), "hazard", 181).impulses_travelling().windowed(
        1024, lanes=lanes)


def test_the_compute_floor_counts_the_lanes() -> None:
    one, two = _records_job(1), _records_job(2)
    assert (one.lanes, two.lanes) == (1, 2)
    bodies = 2 * one.bodies.num_bodies
    assert one.compute_floor_cycles == one.manifold_passes + bodies
    assert two.compute_floor_cycles == one.manifold_passes / 2 + bodies
    preset = get_preset("zcu102")
    assert cm.predict_job(two, preset).cycles >= two.compute_floor_cycles  # a floor, not a prediction


def test_predict_job_dispatches_to_the_window_model() -> None:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    job = KernelJob.from_frame(frame, FP32, SolverParams(4), "hazard", 181)
    preset = get_preset("zcu102")
    streaming = cm.predict_job(job, preset)
    win = job.windowed(1024, fetch_passes=2, lanes=2)
    p = cm.predict_job(win, preset)
    assert not isinstance(streaming, wm.WindowPrediction) and isinstance(p, wm.WindowPrediction)
    assert win.record_window is not None and p.plan == win.record_window
    step = ks.StepShape.of_job(win)
    assert np.array_equal(step.body_a < 0, win.slots < 0)  # empty lanes name no body
    direct = wm.predict_window(cycle_model.job_shape(win, preset, 128), cycle_model.job_timing(win, preset, False), step,
                               win.record_window)
    assert np.array_equal(p.retire, direct.retire) and p.cycles == direct.cycles
    assert p.manifold_passes == win.manifold_passes and p.overwritten == 0
    # compare_retire_cycles on the window's retire order, and its message names the window's reasons
    counters = {"stalls": p.stalls, "bubbles": p.bubbles}
    assert retire_cycles.compare_retire_cycles(p, p.retire, p.kind, p.iteration, p.slot, p.cycles, win.slots, counters).ok
    late = p.retire.copy()
    late[50:] += 2
    msg = retire_cycles.compare_retire_cycles(p, late, p.kind, p.iteration, p.slot, p.cycles + 2, win.slots).first_mismatch
    assert msg is not None and "retire #50) retired at cycle" in msg and "a candidate from cycle" in msg
    with pytest.raises(ValueError, match="not bounded"):
        cm.lower_bound(win, preset)
    section = retire_cycles.report_section(p, preset, 0.1, measured=p.cycles - 5)
    assert "not a bound" in str(section["model vs RTL cycles"])


def test_bad_input() -> None:
    step, plan = one_manifold()
    with pytest.raises(ValueError, match="refuses"):
        wm.predict_window(SHAPE, IDEAL, step, dataclasses.replace(plan, lag=3))  # (2 - 1) * 3 + 2 > 4
    with pytest.raises(ValueError, match="same slots"):
        wm.predict_window(SHAPE, IDEAL, step, dataclasses.replace(plan, slots=np.array([0, -1])))
    with pytest.raises(ValueError, match="no window record layout"):
        wm.predict_window(dataclasses.replace(SHAPE, window_beats=0), IDEAL, step, plan)
