"""Cycle model of the streaming PGS kernel (``rtl/pgs_kernel.sv`` without a record window) behind the compiled harness's
DMA model.

It predicts, without running Verilator, the cycle at which every manifold-pass retires (the ``trace.bin`` cycle
of ``sim/harness/pgs_kernel_main.cpp``), the kernel's stall and bubble counters and its total cycles
(register 0x60). Everything below is read off the RTL and the harness; cycles count from 0 = the first cycle in
LOAD (the harness's ``s.cycle - start_cycle``), the cycle in which a value is visible before the clock edge.

Harness (deterministic streams: random gap 0 and backpressure 0)
    * DDR: a token bucket of bytes, ``rate`` = the preset's bytes per cycle rounded to 1/1000 byte, capped at
      two constraint beats, in IEEE doubles (the model repeats the harness's additions in its order, so a
      credit that lands exactly on a beat size resolves the same way). Each cycle: refill, then the body-in
      beat is offered (and spends), then the constraint beat, then m_axis TREADY = credit for a body-out beat.
    * A beat is offered when the previous one was taken, its transfer's start-up latency ``S`` has run out
      (the body-in transfer and each pass's transfer: first beat offered ``S`` cycles after the previous
      pass's last beat was taken, at cycle ``S - 1`` for the first transfers) and the bucket holds its bytes.
Kernel
    * LOAD: body-in records (``body_in_beats`` each) take one beat per cycle; the last body's final beat at
      cycle ``L`` is written at ``L + 2``, SOLVE starts at ``L + 3``.
    * Constraint assembler (``pgs_record_asm``): one accumulation register and the record register; the first
      beat of record ``r`` is taken no earlier than ``m(r-1)``, the cycle record ``r-1`` moves into the record
      register, ``m(r) = max(final beat(r) + 1, issue(r-1))``; record ``r`` is valid (assembled) from
      ``m(r) + 1``. A contact record of two beats thus issues at most every other cycle.
    * Issue of record ``r`` at the first cycle >= its valid cycle and SOLVE's start with: no dynamic body in
      flight (a manifold is in the hazard CAM from its issue to its retire cycle inclusive: a conflicting
      record issues at ``retire + 1`` at the earliest), with two pipes per lane (``SHARED_DATAPATH = 0``) at a
      contact/friction switch the other pipe drained (``retire of the last issued + 1``), fewer than
      ``HAZARD_DEPTH`` in flight. It retires at ``issue + 1 + LATENCY`` of the lane's datapath (the shared
      datapath's for both kinds, else its kind's pipe's; ``LATENCY`` from ``rtl/generated/pipe_latency.json``).
      With banked body velocities (``BODY_BANKS``, :mod:`models.kernel.body_banks`) it also waits while a bank cannot
      serve the reads of its bodies A and B beside the writes of the manifold retiring in that cycle
      (:class:`BankWrites`).
      Records the kernel rejects (a body index >= num_bodies, the same body twice, two static bodies; such a
      slot stays rejected for the whole step) are consumed at their valid cycle without issuing.
    * Impulses in the records (:class:`ImpulseOut`): every take queues an impulse-out record, taken the cycle after
      its retire (a rejected record's: after its take) and after the one before; a take waits while the order FIFO
      (``IMP_FIFO_DEPTH``) is full, which with TREADY up never happens (a record leaves at most LATENCY + 2 cycles
      after its take). Record s of pass p > 0 is offered no earlier than the turnaround after pass p - 1's
      impulse-out record of slot s was taken; DONE waits for the last impulse-out record.
    * DRAIN until the last retire ``R``; INTEG from ``R + 2``: body ``k`` issues one per cycle while fewer than
      ``OUT_FIFO_DEPTH`` bodies are in the pipe or the output FIFO, leaves the integrate pipe ``LATENCY + 1``
      cycles later, and its ``body_out_beats`` beats follow one per cycle (the first at ``issue + 2 +
      LATENCY``). The last beat at ``P`` ends the step: DONE at ``P + 1``, cycles register ``P + 3``.
Counters: a stall cycle is a SOLVE cycle with a record valid that does not issue; a bubble a SOLVE cycle
without one (SOLVE ends with the last issue).

Not modeled: bad input other than rejected slots (a bad body-in record, non-finite words and truncated
records change only which records issue, see rtl/README.md) and the random gaps/backpressure of the harness:
with those the model's figures are lower bounds (:func:`lower_bound`). The cocotb path
(``cocotb_tests/tb/host_driver.py``) arms the first transfers before ap_start: ``DmaTiming(prefetched=True)``
is its lower bound.

The window kernel has its own model (``models/timing/window_cycle_model.py``); both build on the pieces of
``models/timing/prediction.py`` (the prediction, the DDR bucket, LOAD, DRAIN, INTEG and DONE), and
``models/timing/cycle_model.py`` picks the model of a job.

    pred = predict(shape, dma, step)
    pred.cycles, pred.retire, pred.explain(812)
"""

from __future__ import annotations

from array import array
from itertools import chain

import numpy as np

from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS
from models.golden.shock_propagation import FREEZE_A, FREEZE_B
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.timing.prediction import (BANK_BUSY, CAM_FULL, HAZARD, IMP_FULL, READY, SOLVE_START, SWITCH, BankWrites,
                                      DdrBucket, ImpulseOut, Prediction, Tail, body_beat_cycles, dynamic_bodies, empty,
                                      first_offer_cycle, load_end_cycle)


def predict(shape: KernelShape, dma: DmaTiming, step: StepShape) -> Prediction:
    """Run the cycle model (O(cycles of streaming) in plain Python, seconds for the thesis frame)."""
    nb = step.num_bodies
    if nb == 0:  # IDLE -> INTEG -> DONE: nothing is streamed
        return empty(shape, done=1)
    load_end = load_end_cycle(shape, dma, nb)
    solve_start = load_end + 3
    solve = _solve(shape, dma, step, body_beat_cycles(shape, nb, load_end), solve_start)
    tail = Tail.after_solve(shape, nb, solve_start, solve.end if solve.takes else None, solve.last_retire,
                            solve.last_impulse_out)
    pred = solve.prediction(shape, step, solve_start, tail.integ_start, tail.done)
    pred.phases = tail.phases
    return pred



class _Solve:
    """SOLVE's records in take order, filled by :func:`_solve`; the rare fields (stall causes, rejected
    records) are kept sparse."""

    FIELDS = ("ready", "issue", "first_offer", "last_beat", "ddr_wait")

    def __init__(self) -> None:
        self.cols = {name: array("q") for name in self.FIELDS}
        self.waits: dict[int, tuple[int, int]] = {}  # issued index -> (cause, blocker) when cause != READY
        self.rejected: list[int] = []  # stream indices (pass * slots + slot) of rejected records
        self.takes = self.stalls = 0
        self.end = 0  # the last take
        self.last_retire = -1
        self.last_impulse_out = -1  # impulses in the records: the cycle the last impulse-out record was taken

    @property
    def issued(self) -> int:
        return len(self.cols["issue"])

    def prediction(self, shape: KernelShape, step: StepShape, solve_start: int, integ_start: int,
                   done: int) -> Prediction:
        col = {k: np.frombuffer(v, dtype=np.int64).copy() if len(v) else np.zeros(0, np.int64)
               for k, v in self.cols.items()}
        nm = max(step.num_slots, 1)
        idx = np.setdiff1d(np.arange(self.takes, dtype=np.int64), np.asarray(self.rejected, np.int64),
                           assume_unique=True)
        kinds = np.array([k for k, _ in step.passes] or [0], dtype=np.int64)
        iters = np.array([i for _, i in step.passes] or [0], dtype=np.int64)
        kind, slot = kinds[idx // nm], idx % nm
        cause = np.full(self.issued, READY, dtype=np.int64)
        blocker = np.full(self.issued, -1, dtype=np.int64)
        if self.waits:
            at = np.fromiter(self.waits, dtype=np.int64, count=len(self.waits))
            cb = np.array(list(self.waits.values()), dtype=np.int64)
            cause[at], blocker[at] = cb[:, 0], cb[:, 1]
        latency = np.where(kind == CONTACT_PASS, shape.contact_latency, shape.friction_latency)
        issue, ready = col["issue"], col["ready"]
        prev_issue = np.concatenate([[solve_start - 1], issue[:-1]]) if self.issued else issue
        bubble = np.maximum(0, ready - np.maximum(prev_issue + 1, solve_start))
        dyn_a, dyn_b = dynamic_bodies(step)
        span = self.end - solve_start + 1 if self.takes else 0
        return Prediction(shape, kind, iters[idx // nm], slot, ready, issue, issue + 1 + latency, cause, blocker,
                          bubble, col["first_offer"], col["last_beat"], col["ddr_wait"], dyn_a[slot], dyn_b[slot],
                          solve_start, self.end, integ_start, done, len(self.rejected), self.stalls,
                          span - self.takes - self.stalls)



def _solve(shape: KernelShape, dma: DmaTiming, step: StepShape, body_beats: tuple[int, int],
           solve_start: int) -> _Solve:
    """Constraint stream (with the DDR bucket, shared with the body-in beats ``body_beats`` = first, last
    cycle), assembler, issue and retire of every record of every pass, in stream order. One hot loop: the
    bucket is inlined (the harness's operations in its order)."""
    out = _Solve()
    nm = step.num_slots
    if nm == 0 or not step.passes:
        return out
    nb = step.num_bodies
    free = nb  # stands in for static bodies: never in flight
    dyn_a, dyn_b = dynamic_bodies(step)
    a_list = np.where(dyn_a >= 0, dyn_a, free).tolist()
    b_list = np.where(dyn_b >= 0, dyn_b, free).tolist()
    rej = step.rejected_slots().tolist()
    last_ret = [-1] * (nb + 1)  # per body: retire cycle of the last manifold naming it
    last_who = [-1] * (nb + 1)  # and its retire index
    lat = {CONTACT_PASS: shape.contact_latency, FRICTION_PASS: shape.friction_latency}
    drains = not shape.shared_datapath  # two pipes per lane: the other pipe drains at a switch of kinds
    nbeats = {CONTACT_PASS: shape.contact_beats, FRICTION_PASS: shape.friction_beats}
    depth = shape.hazard_depth
    pass_gap = max(1, dma.startup)  # after a pass's last beat: the next transfer's start-up latency
    offer_from = first_offer_cycle(dma)  # earliest iteration of the next offer
    ddr = DdrBucket(shape, dma, body_beats)
    c = out.cols
    ready_a, issue_a, off_a, beat_a, wait_a = (c[k].append for k in _Solve.FIELDS)
    issued_at, waits, rejected = c["issue"], out.waits, out.rejected
    retired = array("q")  # retire cycle per issued record (for CAM_FULL)
    m_prev = -1  # the cycle record r-1 moved into the record register
    issue_prev = -1  # the take cycle of record r-2, then r-1
    prev = None  # record r-1: (stream index, kind, first offer, last beat, DDR wait)
    last_kind, last_retire, n_iss, stalls = CONTACT_PASS, -1, 0, 0
    # impulses in the records: each take (issued or rejected) queues an impulse-out record (ImpulseOut); record s of
    # the next pass is offered no earlier than `turnaround` cycles after slot s's record was taken (the
    # read-after-write rule)
    in_records, turnaround = shape.impulses_in_records, dma.turnaround
    imp = ImpulseOut(shape.impulse_fifo_depth) if in_records else None
    out_taken = [0] * nm  # per slot: the cycle its latest impulse-out record was taken
    # banked body velocities: per slot the bodies read at issue and the dynamic ones written at retire (BankWrites)
    banks = shape.body_banks
    bank_writes = BankWrites(banks)
    reads = list(zip(step.body_a.tolist(), step.body_b.tolist()))
    writes = [tuple(x for x in (a, b) if x >= 0) for a, b in zip(dyn_a.tolist(), dyn_b.tolist())]
    # a shock pass does not write its rows' frozen bodies (the hazards stay: the CAM holds both)
    shock_writes = writes if step.frozen is None else [
        tuple(x for x, frozen in ((a, f == FREEZE_A), (b, f == FREEZE_B)) if x >= 0 and not frozen)
        for a, b, f in zip(dyn_a.tolist(), dyn_b.tolist(), step.frozen.tolist())]
    shock_pass = step.shock_passes or (False,) * len(step.passes)
    stream = ((p * nm + s, kind, s) for p, (kind, _) in enumerate(step.passes) for s in range(nm))
    for rec in chain(stream, (None,)):
        if prev is not None:  # take record r-1: valid from m_prev + 1
            r_idx, kind, f_off, l_beat, wait = prev
            s = r_idx % nm
            ready = m_prev + 1
            t = ready if ready >= solve_start else solve_start
            if rej[s]:
                rejected.append(r_idx)
                if imp is not None and imp.room_from() > t:
                    t = imp.room_from()
                ret = t
            else:
                cause = READY if ready >= solve_start else SOLVE_START
                who = -1
                a, b = a_list[s], b_list[s]
                ha, hb = last_ret[a] + 1, last_ret[b] + 1
                if ha > t or hb > t:
                    t, cause, who = (ha, HAZARD, last_who[a]) if ha >= hb else (hb, HAZARD, last_who[b])
                if drains and kind != last_kind and last_retire + 1 > t:
                    t, cause, who = last_retire + 1, SWITCH, n_iss - 1
                if n_iss >= depth and retired[n_iss - depth] + 1 > t:
                    t, cause, who = retired[n_iss - depth] + 1, CAM_FULL, n_iss - depth
                if imp is not None and imp.room_from() > t:
                    t, cause, who = imp.room_from(), IMP_FULL, -1
                while banks:  # the writes retiring at t are served first (models.kernel.body_banks)
                    writer = bank_writes.blocker(t, reads[s])
                    if writer < 0:
                        break
                    t, cause, who = t + 1, BANK_BUSY, writer
                if cause != READY:
                    waits[n_iss] = (cause, who)
                ret = t + 1 + lat[kind]
                last_ret[a] = last_ret[b] = ret
                last_who[a] = last_who[b] = n_iss
                last_ret[free] = last_who[free] = -1
                last_kind, last_retire = kind, ret
                retired.append(ret)
                if banks:
                    bank_writes.add(ret, shock_writes[s] if shock_pass[r_idx // nm] else writes[s], n_iss)
                ready_a(ready)
                issue_a(t)
                off_a(f_off)
                beat_a(l_beat)
                wait_a(wait)
                n_iss += 1
            stalls += t - (ready if ready >= solve_start else solve_start)
            issue_prev = t
            if imp is not None:
                out_taken[s] = imp.push(ret)
        if rec is None:
            break
        r_idx, kind, s = rec
        # the beats of record r: offered when the previous one was taken and the bucket holds a beat; the
        # first is taken no earlier than the accumulation register frees (m_prev), the rest as offered
        f_off = x = wait = 0
        for j in range(nbeats[kind]):
            y = offer_from
            if j == 0 and in_records and r_idx >= nm and out_taken[s] + turnaround > y:
                y = out_taken[s] + turnaround  # waits for the previous pass's write of the slot's impulses
            y0 = y
            y = ddr.offer(y)
            wait += y - y0
            if j == 0:
                f_off = y
                x = y if y > m_prev else m_prev
            else:
                x = y
            offer_from = x + 1
        if s == nm - 1:  # TLAST taken: the host starts the next pass's transfer
            offer_from = x + pass_gap
        m_prev = x + 1 if x + 1 > issue_prev else issue_prev
        prev = (r_idx, kind, f_off, x, wait)
    out.takes = len(issued_at) + len(rejected)
    out.stalls = stalls
    out.end = issue_prev
    out.last_retire = last_retire
    out.last_impulse_out = imp.last if imp is not None else -1
    return out
