"""Cycle model of the window kernel (``rtl/pgs_kernel.sv`` built with ``WINDOW`` > 0: ``rtl/pgs_window.sv`` and the
``g_window`` branch and lanes of ``rtl/pgs_sequencer.sv``) behind the compiled harness's DMA model.

Like :mod:`models.timing.cycle_model` (the streaming kernel; its conventions, its harness DMA model and its LOAD, DRAIN,
INTEG and DONE phases hold here unchanged) it predicts, without Verilator, the cycle every manifold-pass retires,
the stall and bubble counters and the total cycles (register 0x60) of a deterministic run (random gap 0,
backpressure 0). Cycles count from 0 = the first cycle in LOAD. Read off the RTL:

Fetch (``pgs_window``, during LOAD and SOLVE)
    * The stream is ``ceil(passes / fetch_passes)`` fetches of ``nm / LANES`` window records of ``REC_BEATS`` =
      LANES x (beats of one lane's window record) beats, TLAST on each fetch's last beat: the harness starts the
      next transfer then (its first beat offered ``startup`` cycles after that TLAST), and the DDR bucket is the
      streaming model's (:class:`models.timing.prediction.DdrBucket`: body-in beats spend first).
    * The assembler takes one beat a cycle while the ring has room: ``used < DEPTH``, where ``used`` counts the
      records whose final beat was taken in an earlier cycle less the takes of a fetch's last pass in earlier
      cycles. Global record ``g`` (fetch x records + record) whose final beat is
      taken at ``x`` is in the ring (``wr_cnt``) from ``x + 3`` (accumulator, record register, ring write).
Passes (``pgs_window``)
    * Pass ``j`` is started (context ``j mod CTX``, slot 0, record base = its fetch x records) in the first cycle
      with ``j - jlo < CTX`` and, for the last pass of a fetch, ``jlo`` >= the fetch's first pass (every pass of
      the earlier fetches done: the last passes free the ring in the order it was written), one a cycle, active
      from the next cycle: with CTX passes per fetch, passes 0 .. CTX - 1 start in cycles 0 .. CTX - 1. ``jlo`` (the
      oldest pass not done) moves on one cycle after its pass took its last slot, one pass a cycle.
    * The slot ``s`` of an active pass ``j`` is *eligible* when its record is in the ring and pass ``j - 1`` is
      done or has stepped at least ``s + lag`` slots (passes never overtake, so they finish in order).
    * The offered candidate is the oldest eligible pass not skipped, else the oldest eligible one. A cycle with a
      candidate and no take marks the offered pass skipped (or, if every eligible pass was skipped, clears the
      marks); a take clears them. LOAD offers too (pass 0's slot 0 from its arrival), so the marks SOLVE starts
      with are modeled.
Take (``pgs_sequencer``)
    * ``take = in SOLVE && candidate && imp_room && (no lane issues || (no hazard && CAM not full && no bank
      busy))``. A record's lanes issue together: those not empty (an all-ones header) and not rejected (a body
      index out of range, the same body twice, two static bodies, or a dynamic body shared with an earlier issuing
      lane of the record; such a slot is rejected in every pass). A hazard is a dynamic body of an issuing lane in
      flight (from its issue to its retire cycle inclusive). Every issued lane retires ``C_LAT + 1`` cycles after
      the issue (the shared datapath's latency, ``shape.contact_latency``, for both kinds; with two pipes per lane
      the friction pipe is delayed to the contact pipe's), lane by lane in the trace. A record
      whose lanes are all rejected or empty is consumed in one cycle.
    * A take steps its pass; the take of a fetch's last pass frees the record's ring entry (from the next cycle).
      SOLVE ends with the last pass's last slot; DRAIN, INTEG and DONE follow as in the streaming kernel.
Banked body velocities (``BODY_BANKS``: :class:`models.timing.prediction.BankWrites`)
    * In a cycle the banks serve the writes of the manifold(s) retiring then (the dynamic bodies of its issuing
      lanes) first, then the reads of the *offered* record's issuing lanes' bodies A and B; where a bank would need a
      third access the record is not taken (a stall: the skip marks treat it as any offered record not taken).
    * With lanes, a lane whose bodies A and B would have the record's issuing lanes read a bank more than twice is
      rejected (error 4, like a lane sharing a dynamic body; the host's plan never makes one).
Impulses in the records (``IMPULSES_IN_RECORDS``: :class:`models.timing.prediction.ImpulseOut`)
    * Each fetch serves passes of one kind and streams that kind's records with impulses (``window_beats`` per lane,
      the same for both kinds); the DDR bucket's rate is the read share (``StreamLayout.ddr_read_share``).
    * The take of a fetch's last pass pushes an entry into the impulse-out order FIFO (``IMP_FIFO_DEPTH``) and its
      retire the data: the record (one per window record, all lanes) is taken the cycle after its retire (a take
      without an issuing lane: after its take) and after the record before it (TREADY always up). ``imp_room``
      (the order FIFO not full) holds every take, of every pass (with TREADY up the FIFO never fills: a record leaves
      at most ``C_LAT + 2`` cycles after its take); DONE waits for the last impulse-out record.
    * The harness offers record ``k`` of fetch ``f > 0`` no earlier than ``turnaround`` cycles after fetch
      ``f - 1``'s impulse-out record ``k`` was taken (:meth:`_Fetch.raw_bound`): the fetch holds that first beat
      until the take of fetch ``f - 1``'s last pass tells when its record leaves.
Counters: a stall cycle is a SOLVE cycle with a candidate and no take, a bubble a SOLVE cycle without one.

The model steps only the cycles in which something can change: a take, a pass start, ``jlo``; between them, a
stretch without a take (no candidate, or every candidate offered in turn blocked) is jumped over whole: nothing
in it changes but the skip marks, which cycle with period ``eligible + 1`` (:func:`_pick_after`), and the fetch,
whose ring room cannot shrink there (no take). The jump lands on the first cycle the offered record's hazards,
CAM and impulse-out room allow its take; a busy bank there (it changes every cycle with the retire) is found by the
cycle-by-cycle check that follows, which then jumps on.

Not modeled: bad input other than rejected slots and empty lanes (as the streaming model), random gaps and
backpressure. Unlike the streaming kernel's, the prediction does not bound runs with random gaps from below: a
delay can change which pass the window offers and so shorten the step (seen: 10% fewer cycles with a lag below the
band). The ring is checked: a record written over an entry a pass still needs (``WindowPrediction.overwritten``)
would mean the kernel read the later record in its place; the last-pass start rule keeps the frees in ring order,
so the count is 0 for every plan the kernel accepts (it stays as a check of the model's ring).

    pred = predict_job(job.windowed(16384, lanes=2), get_preset("zcu102"))   # models.timing.cycle_model dispatches here
    pred.cycles, pred.retire, pred.explain(812)
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from models.kernel.body_banks import over_ports
from models.golden.contact_solver import CONTACT_PASS
from models.timing.prediction import (BANK_BUSY, CAM_FULL, CAUSES, HAZARD, IMP_FULL, READY, SOLVE_START, BankWrites,
                                      DdrBucket, ImpulseOut, Prediction, Tail, body_beat_cycles, build_causes,
                                      dynamic_bodies, first_offer_cycle, load_end_cycle)
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.kernel.record_window import WindowPlan, fits

SELECT = max(CAUSES) + 1  # eligible, but the window offered other passes' records (the skip rotation) until this cycle
# what made a record a candidate last (WindowPrediction.held): its arrival in the ring, its pass's take of the slot
# before (or the pass's start), the pass before it reaching lag slots ahead (or its end)
IN_RING, PASS_AT_SLOT, TRAILING = range(3)
NEVER = 1 << 62  # an event that does not come (a record not in the ring yet)


# --- the prediction -------------------------------------------------------------------------------------
@dataclass
class WindowPrediction(Prediction):
    """:class:`~models.timing.prediction.Prediction` of the window kernel: one entry per issued manifold-pass in retire
    order (takes in order, the lanes of a take in lane order). ``ready``: the cycle the record entered the ring;
    ``first_offer`` / ``last_beat`` / ``ddr_wait``: its fetch's beats."""

    BOUNDS_RANDOM_RUNS: ClassVar[bool] = False  # a delay can change the pass offered and shorten the step

    plan: WindowPlan | None = None
    pass_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # pass of pass_sequence
    eligible: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # first cycle it was a candidate
    held: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # IN_RING, PASS_AT_SLOT or TRAILING
    room_wait: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # its first beat waited for room
    stall_causes: dict[str, int] = field(default_factory=dict)  # stall cycles by what blocked the offered record
    took: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))  # (passes, records): every take
    overwritten: int = 0  # records written over a ring entry a pass still needed (0: the last-pass start rule)
    raw_wait: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # its first beat waited for the
    # impulse-out record of the fetch before (+ turnaround) beyond the stream's pace
    started: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # per pass: the cycle it started
    first_beat: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))  # (fetches, records): the
    # cycle each record's first beat was offered
    impulse_out: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))  # (fetches, records): the
    # cycle its impulse-out record was taken (impulses in the records; else empty)

    def explain(self, k: int) -> str:
        """Why retire #k happens when the model says: the record's fetch and ring entry, its pass's trailing, the
        hazards and the window's choice of pass."""
        plan = self.plan
        assert plan is not None
        iss, rdy, elig = int(self.issue[k]), int(self.ready[k]), int(self.eligible[k])
        j, lanes = int(self.pass_index[k]), plan.lanes
        rec = int(self.slot[k]) // lanes
        what = f"record {rec}" + (f": slots {rec * lanes}..{rec * lanes + lanes - 1}" if lanes > 1 else "")
        lane = ("the shared datapath's latency" if self.shape.shared_datapath
                else "contact pipe latency")
        parts = [f"issue at cycle {iss:,} (pass {j}, {what}), retire at {int(self.retire[k]):,} ({lane} "
                 f"{self.shape.contact_latency} + 1" + ("" if self.shape.shared_datapath
                                                        else ": the friction pipe is aligned to it") + ")"]
        arrival = (f"in the ring from cycle {rdy:,} (its {lanes * self.shape.window_beats} beats offered from "
                   f"{int(self.first_offer[k]):,}, last taken at {int(self.last_beat[k]):,}")
        waits = ((int(self.raw_wait[k]), "the fetch before's impulse-out record of it (+ turnaround)"),
                 (int(self.room_wait[k]), "ring room"), (int(self.ddr_wait[k]), "DDR credit"))
        for n, resource in waits:
            arrival += f", {_cycles(n)} waiting for {resource}" if n else ""
        parts.append(arrival + ")")
        why = {IN_RING: "its arrival in the ring", PASS_AT_SLOT: f"pass {j} had taken its slot before",
               TRAILING: f"pass {j - 1} was {plan.lag} slot{'s' if plan.lag > 1 else ''} ahead or done"}[
                   int(self.held[k])]
        parts.append(f"a candidate from cycle {elig:,} ({why})")
        if self.bubble[k]:
            parts.append(f"{_cycles(int(self.bubble[k]))} without a candidate since the take before (bubbles)")
        parts.append(self._wait(k, int(self.cause[k]), _cycles(iss - max(elig, self.solve_start))))
        return "; ".join(parts)

    def _wait(self, k: int, cause: int, waited: str) -> str:
        """What held retire #k from the cycle it became a candidate (and SOLVE ran) to its issue."""
        plan, b = self.plan, int(self.blocker[k])
        assert plan is not None
        if cause == HAZARD:
            lanes_k = self.issue == self.issue[k]  # the record's issuing lanes: the bodies the CAM compares
            mine = {int(x) for x in np.concatenate([self.body_a[lanes_k], self.body_b[lanes_k]]) if x >= 0}
            shared = sorted(mine & {int(x) for x in (self.body_a[b], self.body_b[b]) if x >= 0})
            together = " (its lanes issue together)" if plan.lanes > 1 else ""
            return (f"waited {waited} for the hazard on the record's body {', '.join(map(str, shared))}{together} "
                    f"with {self.retire_of(b)}")
        return {READY: "no stall: taken the cycle it became a candidate", SOLVE_START: self.solve_wait(),
                SELECT: f"waited {waited}: the window offered other passes' records (the oldest eligible pass not "
                        "skipped since the last take first)",
                CAM_FULL: f"waited {waited}: hazard CAM full ({self.shape.hazard_depth} in flight) until "
                          f"{self.retire_of(b) if b >= 0 else ''}",
                BANK_BUSY: f"waited {waited}: a body-velocity bank busy with the writes of "
                           f"{self.retire_of(b) if b >= 0 else ''} in the cycle before",
                IMP_FULL: f"waited {waited}: {self.imp_full_wait()}"}[cause]

    def stall_cycles_by_cause(self) -> dict[str, int]:
        return dict(self.stall_causes)

    def summary(self) -> dict[str, int | float]:
        out = super().summary()
        if self.overwritten:
            out["ring records overwritten while a pass still needed them (the kernel read others)"] = self.overwritten
        return out


def _cycles(n: int) -> str:
    return f"{n:,} cycle{'' if n == 1 else 's'}"


def predict_window(shape: KernelShape, dma: DmaTiming, step: StepShape, plan: WindowPlan,
                   jumps: bool = True) -> WindowPrediction:
    """The cycle model of ``step`` on the window kernel of ``plan`` (its build: ``depth``, ``ctx``, ``lanes``; its
    arguments: ``lag``, ``fetch_passes``; its slots: ``plan.slots``, -1 an empty lane) with the timing of
    ``shape`` and the harness DMA model ``dma``. ``jumps=False`` steps every cycle (the same prediction, slower:
    what the stretch jumps are checked against)."""
    _check(shape, step, plan)
    nb = step.num_bodies
    if nb == 0:  # IDLE -> INTEG -> DONE: nothing is streamed
        return _prediction(shape, step, plan, _Takes(), 0, Tail(0, 1, {}), _Fetch.none(), [])
    load_end = load_end_cycle(shape, dma, nb)
    solve_start = load_end + 3
    solve = _WindowSolve(shape, dma, step, plan, body_beat_cycles(shape, nb, load_end), solve_start, jumps)
    takes = solve.run()
    tail = Tail.after_solve(shape, nb, solve_start, takes.end if takes.count else None, takes.last_retire,
                            takes.last_impulse_out)
    return _prediction(shape, step, plan, takes, solve_start, tail, solve.fetch, solve.started)


def _check(shape: KernelShape, step: StepShape, plan: WindowPlan) -> None:
    """A ValueError for what the window kernel refuses or the model does not know."""
    if not fits(plan.depth, plan.ctx, plan.lag, plan.fetch_passes):
        raise ValueError(f"window plan {plan}: the kernel refuses it (error code 3: needs 1 <= fetch_passes <= ctx, "
                         "lag >= 1 and (fetch_passes - 1) * lag + 2 <= depth)")
    if any(n < 1 or n & (n - 1) for n in (plan.depth, plan.ctx, plan.lanes)) or plan.ctx < 2:
        raise ValueError(f"window depth ({plan.depth}), contexts ({plan.ctx}, at least 2) and lanes ({plan.lanes}) "
                         "must be powers of two")
    if len(plan.slots) != step.num_slots or step.num_slots % plan.lanes:
        raise ValueError(f"{step.num_slots} slots in the step, {len(plan.slots)} in the window plan: the same slots "
                         f"(a multiple of {plan.lanes} lanes) are needed")
    if shape.window_beats < 1:
        raise ValueError("the kernel shape has no window record layout (KernelShape.of without record_bits)")
    if shape.friction_latency > shape.contact_latency:
        raise ValueError("the window kernel needs the friction pipe no deeper than the contact pipe")


# --- the records --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Records:
    """Per window record (the same in every pass): what its take does."""

    bodies: list[tuple[int, ...]]  # the dynamic bodies of its issuing lanes (the CAM's hazard check and entry;
    # the bodies its retire writes)
    go: list[tuple[tuple[int, tuple[int, ...]], ...]]  # its issuing lanes in lane order: (slot, dynamic bodies)
    rejected: list[int]  # its rejected lanes (not empty, not issuing)
    reads: list[tuple[int, ...]]  # bodies A and B of its issuing lanes (the body banks' reads while it is offered)

    @staticmethod
    def of(step: StepShape, plan: WindowPlan, banks: int = 0) -> "_Records":
        """``banks`` > 0 (banked body velocities): a lane whose bodies A and B would have the issuing lanes read a
        bank more than twice is rejected like a lane sharing a dynamic body with an earlier one."""
        lanes = plan.lanes
        a, b = step.body_a.tolist(), step.body_b.tolist()
        empty = np.asarray(plan.slots) < 0
        bad = (step.rejected_slots() & ~empty).tolist()
        dyn_a, dyn_b = (d.tolist() for d in dynamic_bodies(step))
        bodies: list[tuple[int, ...]] = []
        go: list[tuple[tuple[int, tuple[int, ...]], ...]] = []
        rejected: list[int] = []
        reads: list[tuple[int, ...]] = []
        for r in range(step.num_slots // lanes):
            mine: list[int] = []
            issuing: list[tuple[int, tuple[int, ...]]] = []
            read: tuple[int, ...] = ()
            nrej = 0
            for s in range(r * lanes, r * lanes + lanes):
                if empty[s]:
                    continue
                own = tuple(x for x in (dyn_a[s], dyn_b[s]) if x >= 0)
                # rejected: bad, a dynamic body of an earlier issuing lane, or a bank's ports (error 4)
                if bad[s] or any(x in mine for x in own) or (lanes > 1 and banks
                                                             and over_ports(banks, read + (a[s], b[s]))):
                    nrej += 1
                    continue
                mine += own
                read += (a[s], b[s])
                issuing.append((s, own))
            bodies.append(tuple(mine))
            go.append(tuple(issuing))
            rejected.append(nrej)
            reads.append(read)
        return _Records(bodies, go, rejected, reads)


# --- the fetch ----------------------------------------------------------------------------------------------
class _Fetch:
    """The constraint stream into the ring: per global record (fetch x records per pass + record) the cycle it
    enters the ring. Beats are taken in stream order as far as the caller asks (:meth:`advance`), the ring room of
    a beat from the caller's count of freed records: a call must come before the takes of its cycle and after the
    cycle of every take (a first beat found without room is then taken in the cycle after that take). With the
    impulses in the records (``turnaround`` not None) the caller tells when each record's impulse-out record is
    taken (:meth:`impulses_out`), and a first beat that reads after one not yet known is held until then."""

    def __init__(self, ddr: DdrBucket | None, rec_beats: int, records: int, fetches: int, depth: int, first: int,
                 gap: int, turnaround: int | None = None) -> None:
        self.ddr, self.rec_beats, self.records, self.depth, self.gap = ddr, rec_beats, records, depth, gap
        self.total = records * fetches
        self.arrival = array("q", [NEVER]) * self.total  # the cycle it is in the ring (wr_cnt counts it)
        self.first_offer = array("q", [0]) * self.total
        self.last_beat = array("q", [0]) * self.total
        self.ddr_wait = array("q", [0]) * self.total
        self.room_wait = array("q", [0]) * self.total
        self.raw_wait = array("q", [0]) * self.total
        self.turnaround = turnaround
        # impulses in the records: the cycle its impulse-out record was taken (NEVER: not known yet)
        self.out = array("q", [NEVER]) * (self.total if turnaround is not None else 0)
        self.g = 0  # the record being assembled
        self.beat = 0  # its next beat
        self.waited = False  # that beat (a first one) found no room at an earlier call
        self.held = -1  # that beat (a first one) waits for the impulse-out record it reads after: its pace, else -1
        self.off = self._offer(first) if self.total else NEVER  # the cycle the next beat is offered

    @staticmethod
    def none() -> "_Fetch":
        """No stream (no records)."""
        return _Fetch(None, 1, 0, 0, 1, 0, 1)

    def raw_bound(self, g: int) -> int:
        """The earliest cycle the DMA may offer record ``g``'s first beat beyond the stream's own pace (``NEVER``:
        not known yet): with the impulses in the records, fetch ``f > 0``'s record ``k`` no earlier than
        ``turnaround`` cycles after fetch ``f - 1``'s impulse-out record ``k`` was taken (the harness's
        ``ImpulseBuffer.readable``), else 0."""
        if self.turnaround is None or g < self.records:
            return 0
        out = self.out[g - self.records]
        return NEVER if out == NEVER else out + self.turnaround

    def impulses_out(self, g: int, cycle: int) -> None:
        """Record ``g``'s impulse-out record is taken at ``cycle`` (known at its take, earlier than ``cycle``): a
        first beat held for it is offered now."""
        self.out[g] = cycle
        if self.held >= 0 and self.g == g + self.records:
            y, self.held = self.held, -1
            self.off = self._offer(y)

    def _offer(self, y: int) -> int:
        """The cycle the next beat is offered, no earlier than ``y`` (the DDR's wait is counted to its record), or
        ``NEVER`` while a first beat is held for an impulse-out record."""
        g = self.g
        if self.beat == 0:
            bound = self.raw_bound(g)
            if bound >= NEVER:
                self.held = y
                return NEVER
            if bound > y:
                self.raw_wait[g] = bound - y
                y = bound
        off = self.ddr.offer(y) if self.ddr is not None else y
        self.ddr_wait[g] += off - y
        if self.beat == 0:
            self.first_offer[g] = off
        return off

    def advance(self, t: int, free: int) -> None:
        """Take the beats taken by cycle ``t``, ``free`` ring entries freed before it."""
        while self.off <= t:
            g = self.g
            if self.beat == 0:
                if g - free >= self.depth:  # no room: the beat waits for a free
                    self.waited = True
                    return
                x = t if self.waited else self.off  # the room came with the take in the cycle before t
                self.room_wait[g] = x - self.off
                self.waited = False
            else:
                x = self.off
            self.beat += 1
            y = x + 1
            if self.beat == self.rec_beats:  # the record is done: in the ring 3 cycles later
                self.last_beat[g] = x
                self.arrival[g] = x + 3
                self.g, self.beat = g + 1, 0
                if self.g == self.total:
                    self.off = NEVER
                    return
                if self.g % self.records == 0:  # TLAST: the host starts the next fetch's transfer
                    y = x + self.gap
            self.off = self._offer(y)

    def arrival_of(self, g: int, t: int, free: int) -> int:
        """The cycle record ``g`` enters the ring if no take happens from cycle ``t`` on (``NEVER``: it waits for
        ring room or for an impulse-out record). The beats taken on the way stay taken: a later take only adds room
        and tells when impulse-out records leave."""
        while self.arrival[g] == NEVER:
            if self.off == NEVER or (self.beat == 0 and self.g - free >= self.depth):
                return NEVER
            self.advance(max(self.off, t), free)
        return self.arrival[g]

    def overwritten(self, freed: np.ndarray) -> int:
        """Records written into a ring entry whose record (``depth`` before them) its fetch's last pass had not taken
        yet (``freed[g]``: that take's cycle): the kernel then reads the later record in its place."""
        d = self.depth
        if self.total <= d:
            return 0
        write = np.frombuffer(self.last_beat, np.int64)[d:] + 2  # the ring write; a take in that cycle reads first
        return int(np.count_nonzero(freed[:-d] > write))


# --- the skip marks of the window's choice ------------------------------------------------------------------
def _fresh(skip: int, elig: list[int], ctx_mask: int) -> list[int]:
    """The eligible passes (oldest first) whose context is not marked skipped."""
    return [j for j in elig if not skip >> (j & ctx_mask) & 1]


def _offered(skip: int, elig: list[int], ctx_mask: int) -> int:
    """The pass the window offers: the oldest eligible one whose context is not marked skipped, else the oldest."""
    for j in elig:
        if not skip >> (j & ctx_mask) & 1:
            return j
    return elig[0]


def _pick_after(skip: int, elig: list[int], ctx_mask: int, need: list[int], limit: int) -> int:
    """With the eligible passes ``elig`` (oldest first) unchanged and no take from now (``i`` = 0) on: the first
    ``i`` in [1, ``limit``) at which the offered pass ``elig[x]`` may be taken (``i >= need[x]``), else ``limit``.

    The offers from marks ``skip``: the passes not marked, in order (each offer marks its pass), then the oldest
    (all marked: the marks clear), then round after round of ``elig`` in order followed by the oldest again."""
    fresh = _fresh(skip, elig, ctx_mask)
    k, m = len(fresh), len(elig)
    at = {j: x for x, j in enumerate(elig)}
    best = limit
    for i, j in enumerate(fresh[1:], 1):
        if i >= need[at[j]]:
            best = min(best, i)
            break
    if k and k >= need[0]:
        best = min(best, k)
    for x in range(m):
        firsts = (k + 1 + x, k + 1 + m) if x == 0 else (k + 1 + x,)
        for first in firsts:
            lb = max(first, need[x])
            best = min(best, first + -(-(lb - first) // (m + 1)) * (m + 1))
    return best


def _skip_after(skip: int, elig: list[int], ctx_mask: int, i: int) -> int:
    """The marks ``i`` cycles on with ``elig`` unchanged and no take (see :func:`_pick_after`)."""
    fresh = _fresh(skip, elig, ctx_mask)
    k = len(fresh)
    if i <= k:
        for j in fresh[:i]:
            skip |= 1 << (j & ctx_mask)
        return skip
    marks = 0
    for j in elig[:(i - k - 1) % (len(elig) + 1)]:
        marks |= 1 << (j & ctx_mask)
    return marks


# --- the passes and the take ------------------------------------------------------------------------------
@dataclass
class _Takes:
    """SOLVE's takes, filled by :meth:`_WindowSolve.run`: per issued lane (retire order) and per step."""

    FIELDS = ("slot", "pass", "record", "issue", "eligible", "held", "cause", "blocker", "bubble")

    cols: dict[str, array] = field(default_factory=lambda: {k: array("q") for k in _Takes.FIELDS})
    count: int = 0  # takes
    end: int = 0  # the last take
    last_retire: int = -1
    last_impulse_out: int = -1  # impulses in the records: the cycle the last impulse-out record was taken
    rejected: int = 0
    stalls: int = 0
    bubbles: int = 0
    # stall cycles with the impulse-out FIFO full, else with the CAM full, else with the offered record held by a busy
    # bank (the others: a hazard held the offered record)
    stall_imp: int = 0
    stall_cam: int = 0
    stall_bank: int = 0
    freed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # per global record: last pass's take
    took: array = field(default_factory=lambda: array("q"))  # per pass and record: the take cycle


class _WindowSolve:
    """The pass contexts, the window's choice and the sequencer's take, at the cycles where anything happens."""

    def __init__(self, shape: KernelShape, dma: DmaTiming, step: StepShape, plan: WindowPlan,
                 body_beats: tuple[int, int], solve_start: int, jumps: bool = True) -> None:
        self.plan, self.solve_start, self.jumps = plan, solve_start, jumps
        self.recs = _Records.of(step, plan, shape.body_banks)
        self.nrec = step.num_slots // plan.lanes  # records per pass
        self.passes = len(step.passes)
        fp = plan.fetch_passes
        fetches = -(-self.passes // fp) if self.nrec else 0
        self.base = [(j // fp) * self.nrec for j in range(self.passes)]  # global index of the pass's record 0
        self.first = [j - j % fp for j in range(self.passes)]  # the first pass of its fetch
        self.lastg = [j % fp == fp - 1 or j == self.passes - 1 for j in range(self.passes)]  # its takes free
        self.latency = shape.contact_latency + 1  # issue to retire, every lane and kind
        self.cam_depth = shape.hazard_depth
        in_records = shape.impulses_in_records
        self.imp = ImpulseOut(shape.impulse_fifo_depth) if in_records else None
        self.banks = BankWrites(shape.body_banks) if shape.body_banks else None
        self.fetch = _Fetch(DdrBucket(shape, dma, body_beats), plan.lanes * shape.window_beats, self.nrec, fetches,
                            plan.depth, first_offer_cycle(dma), max(1, dma.startup),
                            dma.turnaround if in_records else None)
        self.last_ret = [-1] * (step.num_bodies + 1)  # per body: retire of the last issue naming it
        self.last_who = [-1] * (step.num_bodies + 1)  # and the retire index of that lane
        self.retired = array("q")  # per issue: its retire cycle
        self.first_lane = array("q")  # per issue: the retire index of its first lane
        # per pass: slots stepped, start cycle, the last cycle a busy bank held its offered record (and the retire
        # index whose writes did); per pass and record: the take cycle
        self.slot = [0] * self.passes
        self.started = [NEVER] * self.passes
        self.bank_held = [(-1, -1)] * self.passes
        self.took = array("q", [0]) * (self.passes * self.nrec)

    def release(self, r: int) -> tuple[int, int, int]:
        """The first cycle record ``r`` may be taken as far as hazards, the hazard CAM and the impulse-out FIFO go,
        with what sets it (``READY``, ``HAZARD``, ``CAM_FULL`` or ``IMP_FULL``) and the retire index of the lane
        whose retire does (else -1)."""
        h, cause, who = 0, READY, -1
        for b in self.recs.bodies[r]:  # in flight from its issue to its retire cycle inclusive
            if self.last_ret[b] + 1 > h:
                h, cause, who = self.last_ret[b] + 1, HAZARD, self.last_who[b]
        n, d = len(self.retired), self.cam_depth
        if self.recs.go[r] and n >= d and self.retired[n - d] + 1 > h:
            h, cause, who = self.retired[n - d] + 1, CAM_FULL, self.first_lane[n - d]
        if self.imp is not None and self.imp.room_from() > h:  # imp_room holds every take
            h, cause, who = self.imp.room_from(), IMP_FULL, -1
        return h, cause, who

    def takeable_from(self, r: int) -> int:
        """The first cycle ``take``'s terms beside the candidate, SOLVE and the body banks allow record ``r``: its
        hazards and the CAM (a record with no issuing lane at once) and ``imp_room``. None of them changes without
        a take; the banks' ``busy`` does every cycle (the retire's writes), so :meth:`bank_busy` checks it in the
        cycle itself."""
        return self.release(r)[0]

    def bank_busy(self, j: int, t: int) -> bool:
        """Whether the body banks keep pass ``j``'s offered record (with issuing lanes) from its take in cycle ``t``:
        the writes of the manifold retiring then leave a bank no port for the record's reads."""
        r = self.slot[j]
        if self.banks is None or not self.recs.go[r]:
            return False
        writer = self.banks.blocker(t, self.recs.reads[r])
        if writer < 0:
            return False
        self.bank_held[j] = (t, writer)
        return True

    def run(self) -> _Takes:
        """Step the cycles from 0 (LOAD) to the last take."""
        out = _Takes()
        out.freed = np.zeros(self.fetch.total, np.int64)
        out.took = self.took
        P, nrec, plan = self.passes, self.nrec, self.plan
        if P == 0 or nrec == 0:
            return out
        ctx_mask, lag, fetch, solve_start = plan.ctx - 1, plan.lag, self.fetch, self.solve_start
        base, slot, arrival, lastg, first = self.base, self.slot, fetch.arrival, self.lastg, self.first
        st_pass = jlo = jdone = free = skip = 0
        t = 0
        while True:
            fetch.advance(t, free)
            # the eligible passes, oldest first (active: started before t, not done; passes finish in order)
            elig: list[int] = []
            for j in range(jdone, st_pass):
                s = slot[j]
                if (j == jdone or slot[j - 1] >= s + lag) and arrival[base[j] + s] <= t:
                    elig.append(j)
            sel = _offered(skip, elig, ctx_mask) if elig else -1
            take = sel >= 0 and t >= solve_start and self.takeable_from(slot[sel]) <= t
            busy = take and self.banks is not None and self.bank_busy(sel, t)
            take = take and not busy
            # the registers at the end of cycle t; a fetch's last pass starts once the earlier fetches are done
            jlo_moves = jlo < st_pass and slot[jlo] == nrec
            starts = st_pass < P and st_pass - jlo < plan.ctx and (not lastg[st_pass] or jlo >= first[st_pass])
            if starts:
                self.started[st_pass] = t
                st_pass += 1
            jlo += jlo_moves
            if take:
                free += self._take(out, sel, t)
                skip = 0
                if slot[sel] == nrec:
                    if sel != jdone:
                        raise RuntimeError(f"window model: pass {sel} finished before pass {jdone}")
                    jdone += 1
                    if jdone == P:
                        out.end = t
                        break
                t += 1
            else:  # no take: on to the next cycle anything can change (the next one after a start or a move of jlo)
                t, skip = self._stretch(out, t, elig, skip, range(jdone, st_pass), free, starts or jlo_moves, busy)
        if self.imp is not None:
            out.last_impulse_out = self.imp.last
        return out

    def _take(self, out: _Takes, j: int, t: int) -> int:
        """Pass ``j`` takes its record at cycle ``t``: its lanes issue (or are rejected); a fetch's last pass queues
        the record's impulse-out record. Returns the ring entries it frees (1 for the fetch's last pass)."""
        nrec = self.nrec
        r = self.slot[j]
        g = self.base[j] + r
        out.count += 1
        out.rejected += self.recs.rejected[r]
        lanes = self.recs.go[r]
        ret = t + self.latency
        if lanes:
            rel, cause, who = self.release(r)
            elig, held = self._eligible_from(j, r)
            if rel < t or t == max(elig, self.solve_start):  # not held by a hazard, the CAM or the FIFO until now
                cause, who = (READY if t == elig else SOLVE_START if t == self.solve_start else SELECT), -1
                if cause == SELECT and self.bank_held[j][0] == t - 1:  # a busy bank, not the window's choice
                    cause, who = BANK_BUSY, self.bank_held[j][1]
            c = out.cols
            first = len(c["slot"])
            self.first_lane.append(first)
            self.retired.append(ret)
            for k, (s, bodies) in enumerate(lanes):
                for col, v in (("slot", s), ("pass", j), ("record", g), ("issue", t), ("eligible", elig),
                               ("held", held), ("cause", cause), ("blocker", who), ("bubble", out.bubbles)):
                    c[col].append(v)
                for b in bodies:
                    self.last_ret[b], self.last_who[b] = ret, first + k
            if self.banks is not None:
                self.banks.add(ret, self.recs.bodies[r], first)
            out.last_retire = ret
        self.took[j * nrec + r] = t
        self.slot[j] = r + 1
        if not self.lastg[j]:
            return 0
        out.freed[g] = t
        if self.imp is not None:  # its data is in at the retire (a take without an issuing lane: at once)
            self.fetch.impulses_out(g, self.imp.push(ret if lanes else t))
        return 1

    def _eligible_from(self, j: int, r: int) -> tuple[int, int]:
        """The first cycle pass ``j``'s record ``r`` was a candidate and what made it one last (``IN_RING``,
        ``PASS_AT_SLOT``, ``TRAILING``): the record in the ring, its pass at the slot, the pass before it far enough
        ahead (or done)."""
        nrec, took = self.nrec, self.took
        since = took[j * nrec + r - 1] + 1 if r else self.started[j] + 1
        lag_from = took[(j - 1) * nrec + min(r + self.plan.lag, nrec) - 1] + 1 if j else 0
        return max((self.fetch.arrival[self.base[j] + r], IN_RING), (since, PASS_AT_SLOT), (lag_from, TRAILING))

    def _count(self, out: _Takes, t: int, n: int, candidate: bool, busy: bool) -> None:
        """Cycles ``t .. t + n - 1`` without a take: SOLVE's are stalls (a candidate) or bubbles; ``busy``: a busy
        bank held the record offered in cycle ``t``."""
        n -= max(0, self.solve_start - t)
        if n <= 0:
            return
        if not candidate:
            out.bubbles += n
            return
        out.stalls += n
        t0 = max(t, self.solve_start)
        if busy:
            out.stall_bank += 1
            t0, n = t0 + 1, n - 1
        full = min(n, max(0, self.imp.room_from() - t0)) if self.imp is not None else 0  # no take at all
        out.stall_imp += full
        k, d = len(self.retired), self.cam_depth
        if k >= d:  # the CAM full until its oldest entry retires
            out.stall_cam += max(0, min(n, self.retired[k - d] + 1 - t0) - full)

    def _stretch(self, out: _Takes, t: int, elig: list[int], skip: int, active: range, free: int,
                 one: bool, busy: bool) -> tuple[int, int]:
        """From cycle ``t`` without a take: the next cycle anything can change and the skip marks then (``one``, or
        without jumps: ``t + 1``). Without a pass start or a move of ``jlo`` in cycle ``t``, the active passes,
        their slots and the room stay until a take; a pass becomes eligible only when its record enters the ring,
        and an eligible one is taken only when offered and released (and then only if no bank is busy: the stretch
        ends at the first such cycle, the caller checks the banks there). ``busy``: a busy bank held the record
        offered in cycle ``t``."""
        plan, fetch, slot = self.plan, self.fetch, self.slot
        one = one or not self.jumps
        nxt = t + 1 if one else NEVER
        wanted = [] if one else [self.base[j] + slot[j] for j in active
                                 if j not in elig and (j == active.start or slot[j - 1] >= slot[j] + plan.lag)]
        if wanted:
            nxt = fetch.arrival_of(min(wanted), t + 1, free)
        if t < self.solve_start:
            nxt = min(nxt, self.solve_start)
        if elig and not one:
            need = [max(self.takeable_from(slot[j]), self.solve_start) - t for j in elig]
            nxt = min(nxt, t + _pick_after(skip, elig, plan.ctx - 1, need, nxt - t))
        if nxt >= NEVER:
            raise RuntimeError(f"window model: no progress after cycle {t:,} (a pass waits for a record the ring has "
                               "no room for, or for an impulse-out record)")
        self._count(out, t, nxt - t, bool(elig), busy)
        return nxt, (_skip_after(skip, elig, plan.ctx - 1, nxt - t) if elig else skip)


# --- the prediction from the takes --------------------------------------------------------------------------
def _prediction(shape: KernelShape, step: StepShape, plan: WindowPlan, takes: _Takes, solve_start: int,
                tail: Tail, fetch: _Fetch, started: list[int]) -> WindowPrediction:
    col = {k: np.frombuffer(v, dtype=np.int64).copy() if len(v) else np.zeros(0, np.int64)
           for k, v in takes.cols.items()}
    kinds = np.array([k for k, _ in step.passes] or [CONTACT_PASS], dtype=np.int64)
    iters = np.array([i for _, i in step.passes] or [0], dtype=np.int64)
    slot, j, g, issue = col["slot"], col["pass"], col["record"], col["issue"]

    def per_record(a: array) -> np.ndarray:
        return np.frombuffer(a, np.int64)[g] if len(a) else np.zeros(0, np.int64)

    bubble = np.diff(col["bubble"], prepend=0)  # bubble cycles since the take before (the first lane of a take)
    dyn_a, dyn_b = dynamic_bodies(step)
    took = np.frombuffer(takes.took, np.int64).reshape(len(step.passes), -1) if len(takes.took) else \
        np.zeros((len(step.passes), 0), np.int64)
    span = takes.end - solve_start + 1 if takes.count else 0
    stalls = {CAUSES[HAZARD]: takes.stalls - takes.stall_cam - takes.stall_bank - takes.stall_imp,
              CAUSES[CAM_FULL]: takes.stall_cam}
    stalls.update({CAUSES[c]: {BANK_BUSY: takes.stall_bank, IMP_FULL: takes.stall_imp}[c] for c in build_causes(shape)})
    per_fetch = (-1, fetch.records) if fetch.records else (0, 0)
    pred = WindowPrediction(
        shape, kinds[j], iters[j], slot, per_record(fetch.arrival), issue, issue + shape.contact_latency + 1,
        col["cause"], col["blocker"], bubble, per_record(fetch.first_offer), per_record(fetch.last_beat),
        per_record(fetch.ddr_wait), dyn_a[slot], dyn_b[slot], solve_start, takes.end if takes.count else solve_start,
        tail.integ_start, tail.done, takes.rejected, takes.stalls, takes.bubbles, tail.phases, plan, j,
        col["eligible"], col["held"], per_record(fetch.room_wait), stalls, took, fetch.overwritten(takes.freed),
        per_record(fetch.raw_wait), np.array(started, np.int64),
        np.frombuffer(fetch.first_offer, np.int64).reshape(per_fetch) if len(fetch.first_offer) else
        np.zeros((0, 0), np.int64),
        np.frombuffer(fetch.out, np.int64).reshape(per_fetch) if len(fetch.out) else np.zeros((0, 0), np.int64))
    if takes.count and takes.stalls + takes.bubbles + takes.count != span:
        raise RuntimeError(f"window model: {takes.stalls} stalls + {takes.bubbles} bubbles + {takes.count} takes "
                           f"!= SOLVE's {span} cycles")
    return pred
